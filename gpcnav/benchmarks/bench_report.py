"""The solver benchmark's document (:func:`gpcnav.benchmarks.solvers.run_bench`) as a reader
sees it: the text table ``gpcnav bench`` prints and its figure."""
from __future__ import annotations

import numpy as np

__all__ = ["format_table", "bench_figure"]


def format_table(doc: dict) -> str:
    """The BENCH rows as a text table."""
    head = (f"{'name':<26} {'kind':<6} {'median ms':>9} {'p95 ms':>8} {'max ms':>8} {'iter':>5} {'success':>7} "
            f"{'cost/best med':>13} {'max':>9} {'as good as ' + doc['reference']:>22} {'steps as good':>13} {'all solves s':>12}")
    lines = [head, "-" * len(head)]
    for r in doc["results"]:
        t = r["time_s"]
        if r["kind"] == "solver":
            c = r["cost_ratio_to_best"]
            vs = r.get("vs_reference") or {}
            st = r.get("planner_steps") or {}
            cells = (f"{r['iterations']['median']:>5.0f} {r['success_rate']:>7.1%} "
                     f"{_num(c['median']):>13} {_num(c['max']):>9} "
                     f"{vs.get('as_good_rate', float('nan')):>22.1%} {_pct(st.get('as_good_rate')):>13} "
                     f"{_num(r.get('total_time_s')):>12}")
        else:
            cells = f"{'':>5} {'':>7} {'':>13} {'':>9} {'':>22} {'':>13} {'':>12}"
        lines.append(f"{r['name']:<26} {r['kind']:<6} {t['median'] * 1e3:>9.3f} {t['p95'] * 1e3:>8.3f} "
                     f"{t['max'] * 1e3:>8.2f} {cells}")
    return "\n".join(lines)


def _pct(v) -> str:
    return "n/a" if v is None else f"{v:.1%}"


def _num(v) -> str:
    return "n/a" if v is None else f"{v:.6f}" if v < 10 else f"{v:.3g}"


def bench_figure(doc: dict):
    """Time per solve (log scale), one box per solver or policy, with the chosen one marked."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib import cbook
    rows = [r for r in doc["results"] if r.get("time_samples_s") or r.get("time_s")]
    fig, ax = plt.subplots(figsize=(max(6.0, 1.0 + 0.9 * len(rows)), 4.2))
    stats, summary_only = [], False
    for r in rows:
        if r.get("time_samples_s"):
            stats += cbook.boxplot_stats(np.asarray(r["time_samples_s"]) * 1e3, whis=(5, 95))
        else:  # a row kept as its summary (the network's bare call): the median, whisker to p95, max
            t = {k: v * 1e3 for k, v in r["time_s"].items() if k in ("median", "p95", "max")}
            stats.append({"med": t["median"], "q1": t["median"], "q3": t["median"], "whislo": t["median"],
                          "whishi": t["p95"], "fliers": [t["max"]]})
            summary_only = True
    box = ax.bxp(stats, showfliers=True, patch_artist=True, flierprops={"markersize": 2})
    chosen = doc["chosen"]["name"]
    for patch, r in zip(box["boxes"], rows):
        patch.set_facecolor("tab:green" if r["name"] == chosen else "tab:blue" if r["kind"] == "solver"
                            else "tab:orange")
        patch.set_alpha(0.5)
    ax.set_yscale("log")
    ax.set_xticks(range(1, len(rows) + 1), [r["name"] for r in rows], rotation=30, ha="right", fontsize=7)
    ax.set_ylabel("time per solve / decision (ms, log scale)")
    ax.set_title(f"{doc['scenario']}, preset {doc['preset']} (H={doc['horizon']}): {doc['problems']} problems\n"
                 f"chosen {chosen} (green); whiskers 5-95 %"
                 + ("; a flat box: a row kept as its median, p95 and max" if summary_only else ""), fontsize=8)
    ax.grid(True, which="both", axis="y", lw=0.3, alpha=0.5)
    fig.tight_layout()
    return fig
