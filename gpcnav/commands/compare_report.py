"""The table and the figure of a COMPARE document (``gpcnav compare``): read from the
document alone, so they can be redrawn from a file."""
from __future__ import annotations

import numpy as np

from scenarios.paired import PAIRED_OUTCOMES, outcome_changes, sign_test

__all__ = ["compare_table", "paired_table", "compare_figure", "episodes_caption"]


def _pct(v) -> str:
    return "-" if v is None else f"{100.0 * v:.1f}"


def _num(v, fmt: str = ".2f") -> str:
    return "-" if v is None else format(v, fmt)


def episodes_caption(doc: dict) -> str:
    """What the episodes were, in words."""
    n = doc["controllers"][0]["episodes"] if doc["controllers"] else 0
    spec = doc.get("suite_spec")
    if spec:
        what = f"suite {spec['suite']}, seed {spec['seed']}"
        if "movers" in spec:
            what += f", {spec['movers']} {spec['behaviour']} movers"
        elif spec.get("behaviour"):  # ucy: the recorded people replayed, or walkers that follow them
            what += f", {spec['behaviour']}"
    else:
        what = "scenario files"
    return f"{n} episodes ({what}), preset {doc.get('preset')}"


def compare_table(doc: dict) -> str:
    """One row per controller, in Markdown: rates with their one-sided 95 % Clopper-Pearson
    upper bounds, time to goal, clearances, CrowdNav's danger measures, decision time."""
    head = ("| controller | success % (>= lower 95 %) | collision % (<= upper 95 %) | timeout % | time to goal s "
            "(mean / median) | min clearance m (min / median) | danger % | path m | decision ms (median / p95) "
            "| fallbacks | interventions |")
    rows = [f"{episodes_caption(doc)}; bounds are one-sided 95 % Clopper-Pearson.", "", head,
            "|" + "---|" * (head.count("|") - 1)]
    for e in doc["controllers"]:
        ttg = e.get("time_to_goal_s")
        ct = e["compute_time_s"]
        rows.append(
            f"| {e['controller']} | {_pct(e['success_rate'])} (>= {_pct(1.0 - e['failure_rate_upper_95'])}) "
            f"| {_pct(e['collision_rate'])} (<= {_pct(e['collision_rate_upper_95'])}) | {_pct(e['timeout_rate'])} "
            f"| {_num(ttg and ttg['mean'], '.1f')} / {_num(ttg and ttg['median'], '.1f')} "
            f"| {_num(e['min_clearance_m']['min'])} / {_num(e['min_clearance_m']['median'])} "
            f"| {_pct(e['danger_rate'])} | {_num(e['path_length_m']['median'], '.1f')} "
            f"| {ct['median'] * 1e3:.3g} / {ct['p95'] * 1e3:.3g} | {e['fallbacks']} | {e.get('interventions', 0)} |")
    return "\n".join(rows)


def paired_table(doc: dict) -> str:
    """Each controller after the first against the first, episode by episode
    (:mod:`scenarios.paired`): the episodes that gained and lost reaching the goal and
    colliding, with the exact sign test of each split; empty when the document's episodes
    carry no outcomes or there is one controller."""
    evals = doc["controllers"]
    rows = [e["episodes_detail"] for e in evals]
    if len(evals) < 2 or not all(all("scenario" in d and "outcome" in d for d in r) for r in rows):
        return ""
    first = evals[0]["controller"]
    head = "| controller | reached the goal: gained / lost (p) | collided: gained / lost (p) |"
    out = [f"Episode by episode against {first}: the episodes each controller reached (or collided in) and "
           f"{first} did not, and the other way round; p, the exact two-sided sign test of that split.", "",
           head, "|---|---|---|"]
    for e, r in zip(evals[1:], rows[1:]):
        changes = outcome_changes(rows[0], r)
        (rg, rl), (cg, cl) = (changes[o] for o in PAIRED_OUTCOMES)
        out.append(f"| {e['controller']} | {rg} / {rl} ({sign_test(rg, rl):.2g}) | {cg} / {cl} ({sign_test(cg, cl):.2g}) |")
    return "\n".join(out)


def compare_figure(doc: dict):
    """Four panels, one row per controller in each: success rate (bar) with the lower 95 %
    bound, collision rate with the upper 95 % bound, time to goal of the successful
    episodes (box), decision time on a log scale (median, whisker to the 95th percentile,
    tick at the largest)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter
    evals = doc["controllers"]
    names = [e["controller"] for e in evals]
    y = np.arange(len(evals))[::-1]
    fig, axes = plt.subplots(1, 4, figsize=(13.0, 1.2 + 0.42 * len(evals)), sharey=True)
    colours = plt.get_cmap("tab10")(np.arange(len(evals)) % 10)

    ax = axes[0]
    rate = np.array([e["success_rate"] for e in evals]) * 100
    low = np.array([1.0 - e["failure_rate_upper_95"] for e in evals]) * 100
    ax.barh(y, rate, color=colours, alpha=0.8)
    ax.errorbar(low, y, xerr=[np.zeros_like(low), rate - low], fmt="|", color="k", capsize=3, lw=1)
    for yi, r in zip(y, rate):  # on a white ground: the whisker may run through it (few episodes)
        ax.text(2, yi, f"{r:.1f}", va="center", fontsize=7, zorder=4,
                bbox={"facecolor": "white", "alpha": 0.85, "pad": 0.6, "linewidth": 0})
    ax.set_xlim(0, 102)
    ax.set_xlabel("reached the goal (%)\nbar: rate, whisker: lower 95 % bound")

    ax = axes[1]
    rate = np.array([e["collision_rate"] for e in evals]) * 100
    up = np.array([e["collision_rate_upper_95"] for e in evals]) * 100
    ax.barh(y, rate, color=colours, alpha=0.8)
    ax.errorbar(rate, y, xerr=[np.zeros_like(rate), up - rate], fmt="|", color="k", capsize=3, lw=1)
    for yi, r, u in zip(y, rate, up):
        ax.text(u + 0.5, yi, f"{r:.1f}", va="center", fontsize=7)
    ax.set_xlim(0, max(5.0, 1.25 * float(up.max(initial=0.0))))
    ax.set_xlabel("collided (%)\nbar: rate, whisker: upper 95 % bound")

    ax = axes[2]
    data = [[d["time_to_goal_s"] for d in e["episodes_detail"] if d["time_to_goal_s"] is not None] for e in evals]
    shown = [i for i, d in enumerate(data) if d]
    if shown:
        kw = dict(positions=y[shown], widths=0.6, whis=(5, 95), patch_artist=True, manage_ticks=False,
                  flierprops={"markersize": 2}, medianprops={"color": "k"})
        try:
            box = ax.boxplot([data[i] for i in shown], orientation="horizontal", **kw)  # matplotlib >= 3.10
        except TypeError:
            box = ax.boxplot([data[i] for i in shown], vert=False, **kw)
        for patch, i in zip(box["boxes"], shown):
            patch.set_facecolor(colours[i])
            patch.set_alpha(0.6)
    for i in set(range(len(evals))) - set(shown):  # an empty row says why
        ax.text(0.02, y[i], "none reached", transform=ax.get_yaxis_transform(), va="center", fontsize=7, color="0.4")
    ax.set_xlabel("time to goal (s), successful episodes\nbox: quartiles, whiskers 5-95 %")

    ax = axes[3]
    med = np.array([e["compute_time_s"]["median"] for e in evals]) * 1e3
    p95 = np.array([e["compute_time_s"]["p95"] for e in evals]) * 1e3
    mx = np.array([e["compute_time_s"]["max"] for e in evals]) * 1e3
    ax.errorbar(med, y, xerr=[np.zeros_like(med), p95 - med], fmt="none", ecolor="k", capsize=3, lw=1)
    ax.scatter(med, y, c=colours, s=40, zorder=3)
    ax.scatter(mx, y, marker="|", c="0.4", s=60, zorder=3)
    ax.set_xscale("log")
    # labels at the decades, and at 2 and 5 of each where the times span less than two; none at
    # the minor ticks (less than a decade of range printed every minor label over the next)
    seen = np.concatenate([med, p95, mx])
    seen = seen[np.isfinite(seen) & (seen > 0)]
    decades = float(np.log10(seen.max() / seen.min())) if seen.size else 0.0
    ax.xaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0) if decades < 2.0 else (1.0,)))
    ax.xaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
    ax.set_xlabel("decision time (ms, log)\ndot: median, whisker: p95, tick: max")
    for a in axes:
        a.grid(True, axis="x", which="both", lw=0.3, alpha=0.5)
        a.set_ylim(-0.7, len(evals) - 0.3)
    axes[0].set_yticks(y, names)
    fig.suptitle(episodes_caption(doc), fontsize=9)
    fig.tight_layout()
    return fig
