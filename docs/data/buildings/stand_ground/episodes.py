"""Episode by episode: the first K people walking at the standing robot (analyse.py's
encounters, in the order they come within GAP_M of it), their mean opening of the miss
distance by then, and when the K-th came within GAP_M (s). How well the mean tells an
episode of people who see the robot from one of blind people (the share of see/blind pairs
ordered right: the AUC)."""
import json
import sys

import numpy as np

from analyse import encounters, opened_at

GAP_M = 2.5


def first_k(ep, k):
    rows = ep["rows"]
    t_of = {}
    encs = encounters(ep)
    out = []
    for s in encs:
        o = opened_at(s, GAP_M)
        if o is None:
            continue
        out.append(o)
    return out[:k]


if __name__ == "__main__":
    see, blind = (json.load(open(p)) for p in sys.argv[1:3])
    for k in (1, 2, 3, 5):
        a = [np.mean(v) for ep in see if len(v := first_k(ep, k)) >= k]
        b = [np.mean(v) for ep in blind if len(v := first_k(ep, k)) >= k]
        if not a or not b:
            continue
        auc = np.mean([(x > y) + 0.5 * (x == y) for x in a for y in b])
        print(f"first {k}: see n {len(a)} median {np.median(a):+.2f} | blind n {len(b)} median {np.median(b):+.2f} | AUC {auc:.2f}")
