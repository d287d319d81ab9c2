"""Train the learned forecast on data.py's samples: an MLP from the walker's past and its
neighbours to its 12 future positions (in its own frame) and one standard deviation per step
(an isotropic Gaussian's negative log-likelihood), exported to ONNX with the input's
normalisation inside.

    python train.py TRAIN.npz OUT.onnx [--epochs N] [--width W]"""
import argparse
import time

import numpy as np
import torch
from torch import nn

H = 12


class Net(nn.Module):
    def __init__(self, n_in, width, x_mean, x_std):
        super().__init__()
        self.register_buffer("x_mean", torch.tensor(x_mean, dtype=torch.float32))
        self.register_buffer("x_std", torch.tensor(x_std, dtype=torch.float32))
        self.body = nn.Sequential(nn.Linear(n_in, width), nn.ReLU(), nn.Linear(width, width), nn.ReLU(),
                                  nn.Linear(width, 3 * H))

    def forward(self, x):
        o = self.body((x - self.x_mean) / self.x_std)
        mean = o[:, :2 * H]
        log_std = torch.clamp(o[:, 2 * H:], -5.0, 2.0)
        return torch.cat([mean, log_std], dim=1)


def nll(out, y):
    mean, log_std = out[:, :2 * H], out[:, 2 * H:]
    e2 = ((mean - y) ** 2).reshape(-1, H, 2).sum(-1)
    return (0.5 * e2 * torch.exp(-2 * log_std) + 2 * log_std).mean()


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("data")
    ap.add_argument("out")
    ap.add_argument("--epochs", type=int, default=30)
    ap.add_argument("--width", type=int, default=256)
    ap.add_argument("--seed", type=int, default=0)
    a = ap.parse_args()
    torch.manual_seed(a.seed)
    torch.set_num_threads(2)
    d = np.load(a.data)
    X, Y = d["X"].astype(np.float32), d["Y"].astype(np.float32)
    n_val = len(X) // 10
    Xt, Yt, Xv, Yv = X[:-n_val], Y[:-n_val], X[-n_val:], Y[-n_val:]  # the last seeds held out
    mu, sd = Xt.mean(0), Xt.std(0) + 1e-3
    net = Net(X.shape[1], a.width, mu, sd)
    opt = torch.optim.Adam(net.parameters(), lr=1e-3)
    sched = torch.optim.lr_scheduler.CosineAnnealingLR(opt, a.epochs)
    Xt_, Yt_, Xv_, Yv_ = map(torch.from_numpy, (Xt, Yt, Xv, Yv))
    best, best_state = np.inf, None
    for ep in range(a.epochs):
        t0 = time.time()
        net.train()
        perm = torch.randperm(len(Xt_))
        for i in range(0, len(perm), 1024):
            idx = perm[i:i + 1024]
            loss = nll(net(Xt_[idx]), Yt_[idx])
            opt.zero_grad()
            loss.backward()
            opt.step()
        sched.step()
        net.eval()
        with torch.no_grad():
            ov = net(Xv_)
            v = float(nll(ov, Yv_))
            err = ((ov[:, :2 * H] - Yv_) ** 2).reshape(-1, H, 2).sum(-1).sqrt()
        if v < best:
            best, best_state = v, {k: t.clone() for k, t in net.state_dict().items()}
        print(f"epoch {ep:3d} val nll {v:.4f} ADE {float(err.mean()):.3f} FDE {float(err[:, -1].mean()):.3f} "
              f"({time.time() - t0:.0f} s)", flush=True)
    net.load_state_dict(best_state)
    net.eval()
    torch.onnx.export(net, torch.zeros(1, X.shape[1]), a.out, input_names=["x"], output_names=["y"],
                      dynamic_axes={"x": {0: "n"}, "y": {0: "n"}}, opset_version=17, dynamo=False)
    print("saved", a.out, "best val nll", best)


if __name__ == "__main__":
    main()
