"""Figures in the style of the paper's Fig. 7 and animations, drawn from RUN documents."""
from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.collections import LineCollection  # noqa: E402
from matplotlib.patches import Circle  # noqa: E402

__all__ = ["plot_run", "run_figure", "animate_run", "animation_view", "mover_colour", "walls_beside"]

_OBSTACLE_COLOURS = ["tab:red", "tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan"]


def mover_colour(j: int, n_moving: int):
    """A colour per mover, distinct for up to 20 (the paper's few obstacles keep their red,
    purple, ...; a crowd gets tab10 or tab20 without the robot's blue)."""
    if n_moving <= len(_OBSTACLE_COLOURS):
        return _OBSTACLE_COLOURS[j % len(_OBSTACLE_COLOURS)]
    cmap = plt.get_cmap("tab20")
    palette = [cmap(i) for i in range(20) if i not in (0, 1)]  # 0, 1: blues (the robot's)
    return palette[j % len(palette)]


WALL_VIEW_M = 1.5
"""How far beyond the robot's, the reference's and the movers' extent a wall beside them
widens the view (a corridor's side 1.25 m from its middle, a room's wall)."""


def walls_beside(walls, xrange, yrange, margin_m: float = WALL_VIEW_M) -> np.ndarray:
    """The points of the wall polylines ``walls`` (each ``(k, 2)``) beside the view
    ``xrange`` x ``yrange``: of a segment running more along x than along y, those within the
    x-range and at most ``margin_m`` above or below the y-range; of one running more along y,
    those within the y-range and at most ``margin_m`` to either side; ``(n, 2)``. A view
    that includes them shows the walls alongside what happens (a room's, a corridor's sides),
    not the lengths of wall running on beyond it (each segment sampled every 5 cm, its ends
    included)."""
    (x0, x1), (y0, y1) = sorted(xrange), sorted(yrange)
    out = []
    for w in walls:
        for a, b in zip(w[:-1], w[1:]):
            k = max(2, int(np.ceil(np.hypot(*(b - a)) / 0.05)) + 1)
            P = a + np.linspace(0.0, 1.0, k)[:, None] * (b - a)
            along_x = abs(b[0] - a[0]) >= abs(b[1] - a[1])
            u, v = (P[:, 0], P[:, 1]) if along_x else (P[:, 1], P[:, 0])
            (u0, u1), (v0, v1) = ((x0, x1), (y0, y1)) if along_x else ((y0, y1), (x0, x1))
            out.append(P[(u >= u0) & (u <= u1) & (v >= v0 - margin_m) & (v <= v1 + margin_m)])
    return np.concatenate(out) if out else np.empty((0, 2))


def plot_run(ax, doc: dict, robot_radius_m: float = 0.35, mark_every_s: float = 3.0, title: str | None = None):
    """Draw one run: reference, robot path with its footprint at intervals, obstacle paths
    with their discs at the same instants, and the time written beside each footprint."""
    tr = doc["trajectory"]
    t = np.asarray(tr["t"])
    x, y, h = (np.asarray(tr[k]) for k in ("x", "y", "heading_rad"))
    if "reference_path" in doc:
        rp = np.asarray(doc["reference_path"])
        ax.plot(rp[:, 0], rp[:, 1], color="0.6", lw=1.0, ls="--", label="reference path")
    ax.plot(x, y, color="tab:blue", lw=1.6, label="robot")
    dt = float(doc["sample_time_s"])
    step = max(1, int(round(mark_every_s / dt)))
    marks = list(range(0, len(t), step))
    for k in marks:
        ax.add_patch(Circle((x[k], y[k]), robot_radius_m, fill=False, color="tab:blue", lw=0.8, alpha=0.8))
        ax.plot([x[k], x[k] + robot_radius_m * np.cos(h[k])], [y[k], y[k] + robot_radius_m * np.sin(h[k])],
                color="tab:blue", lw=0.8)
        ax.annotate(f"{t[k]:.0f}", (x[k], y[k]), fontsize=6, color="tab:blue", ha="center", va="center")
    walls = [np.asarray(w["points"], dtype=float) for w in doc.get("walls", [])]
    if walls:  # walls run on beyond where anyone goes: they do not set the view (autolim off) ...
        ax.add_collection(LineCollection(walls, colors="0.25", linewidths=3.0, capstyle="butt", label="wall"),
                          autolim=False)
    obstacles = doc.get("obstacles", [])
    n_moving = sum(o["kind"] == "moving" for o in obstacles)
    crowd = n_moving > len(_OBSTACLE_COLOURS)
    for j, ob in enumerate(obstacles):
        ox, oy = np.asarray(ob["x"], dtype=float), np.asarray(ob["y"], dtype=float)  # null: not in the scene
        if ob["kind"] == "static":
            ax.add_patch(Circle((ox[0], oy[0]), ob["radius_m"], color="0.3", alpha=0.6))
            continue
        c = mover_colour(j, n_moving)
        ax.plot(ox, oy, color=c, lw=1.0, ls=":", label="moving obstacle" if j == 0 else None)
        for k in marks:
            if k < len(ox) and np.isfinite(ox[k]):
                # later footprints darker: who was where when, even where paths cross
                alpha = 0.35 + 0.65 * k / max(len(t) - 1, 1) if crowd else 1.0
                ax.add_patch(Circle((ox[k], oy[k]), ob["radius_m"], fill=False, color=c, lw=0.8, alpha=alpha))
                ax.annotate(f"{t[k]:.0f}", (ox[k], oy[k]), fontsize=6, color=c, ha="center", va="center")
        if "goal" in ob:
            ax.plot(*ob["goal"], marker="x", color=c, ms=5, mew=1.2)
        if (crowd or doc.get("outcome") == "collided") and np.isfinite(ox[-1]):
            ax.add_patch(Circle((ox[-1], oy[-1]), ob["radius_m"], color=c, alpha=0.35))  # where it was at the end
    if doc.get("outcome") == "collided":
        ax.add_patch(Circle((x[-1], y[-1]), robot_radius_m, color="tab:blue", alpha=0.35))
        ax.plot(x[-1], y[-1], marker="X", color="black", ms=8, label=f"collision at {t[-1]:.1f} s")
    if walls:  # ... but a wall beside what is drawn is in the view (a room's, a corridor's sides)
        near = walls_beside(walls, ax.dataLim.intervalx, ax.dataLim.intervaly)
        if len(near):
            ax.update_datalim(near)
            ax.autoscale_view()
    ax.set_aspect("equal", adjustable="datalim")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.grid(True, lw=0.3, alpha=0.5)
    if title is None:
        title = f"{doc['scenario']} - {doc['controller']}: {doc['outcome']}, clearance {doc['min_clearance_m']:.2f} m"
    ax.set_title(title, fontsize=8)
    return ax


def run_figure(doc: dict, robot_radius_m: float = 0.35):
    fig, ax = plt.subplots(figsize=(8, 4.5))
    plot_run(ax, doc, robot_radius_m)
    ax.legend(fontsize=7, loc="best")
    fig.tight_layout()
    return fig


def animation_view(doc: dict, pad_m: float = 1.0) -> tuple[tuple[float, float], tuple[float, float]]:
    """The animation's x and y limits: what :func:`plot_run`'s view holds (the robot, the
    reference, the movers, and a wall beside them within :data:`WALL_VIEW_M`), ``pad_m`` beyond.
    (Until 2026-12-01 it took walls within 1 m only and not the reference: a robot alone in a
    2.5 m corridor was animated with neither wall in view, and a collided run's path cut short.)"""
    tr = doc["trajectory"]
    parts = [np.column_stack([tr["x"], tr["y"]]).astype(float)]
    if "reference_path" in doc:
        parts.append(np.asarray(doc["reference_path"], dtype=float).reshape(-1, 2))
    parts += [np.column_stack([np.asarray(o["x"], dtype=float), np.asarray(o["y"], dtype=float)])
              for o in doc.get("obstacles", [])]
    pts = np.concatenate(parts)
    (x0, y0), (x1, y1) = np.nanmin(pts, axis=0), np.nanmax(pts, axis=0)
    near = walls_beside([np.asarray(w["points"], dtype=float) for w in doc.get("walls", [])], (x0, x1), (y0, y1))
    if len(near):
        (x0, y0), (x1, y1) = np.minimum((x0, y0), near.min(axis=0)), np.maximum((x1, y1), near.max(axis=0))
    return (float(x0) - pad_m, float(x1) + pad_m), (float(y0) - pad_m, float(y1) + pad_m)


def animate_run(doc: dict, path, robot_radius_m: float = 0.35, fps: int = 8, progress=None) -> None:
    """A GIF of the run, one frame per sample; ``progress``: an optional ``tqdm``-like factory
    ``progress(total=, unit=)``, a bar over the frames drawn."""
    from matplotlib.animation import FuncAnimation, PillowWriter

    from casadi_gpc.io import atomic_file

    tr = doc["trajectory"]
    x, y, h, t = (np.asarray(tr[k]) for k in ("x", "y", "heading_rad", "t"))
    fig, ax = plt.subplots(figsize=(7, 4))
    obs = [{**o, "x": np.asarray(o["x"], dtype=float), "y": np.asarray(o["y"], dtype=float)}  # null: not in the scene
           for o in doc.get("obstacles", [])]
    xlim, ylim = animation_view(doc)
    ax.set_xlim(*xlim)
    ax.set_ylim(*ylim)
    ax.set_aspect("equal")
    if "reference_path" in doc:
        rp = np.asarray(doc["reference_path"])
        ax.plot(rp[:, 0], rp[:, 1], color="0.6", lw=1.0, ls="--")
    for wall in doc.get("walls", []):
        pts = np.asarray(wall["points"], dtype=float)
        ax.plot(pts[:, 0], pts[:, 1], color="0.25", lw=3.0, solid_capstyle="butt")
    path_line, = ax.plot([], [], color="tab:blue", lw=1.2)
    robot = Circle((x[0], y[0]), robot_radius_m, fill=False, color="tab:blue")
    ax.add_patch(robot)
    discs, trails = [], []
    n_moving = sum(o["kind"] == "moving" for o in obs)
    trail_len = max(1, int(round(3.0 / float(doc["sample_time_s"]))))  # the last 3 s of each mover
    for j, o in enumerate(obs):
        c = "0.3" if o["kind"] == "static" else mover_colour(j, n_moving)
        d = Circle((o["x"][0], o["y"][0]), o["radius_m"], color=c, alpha=0.5)
        ax.add_patch(d)
        discs.append(d)
        trails.append(ax.plot([], [], color=c, lw=0.8, alpha=0.7)[0] if o["kind"] == "moving" else None)
        if "goal" in o:
            ax.plot(*o["goal"], marker="x", color=c, ms=4)
    label = ax.set_title("")

    def frame(k):
        path_line.set_data(x[: k + 1], y[: k + 1])
        robot.center = (x[k], y[k])
        for d, tr, o in zip(discs, trails, obs):
            kk = min(k, len(o["x"]) - 1)
            here = bool(np.isfinite(o["x"][kk]))
            d.set_visible(here)
            if here:
                d.center = (o["x"][kk], o["y"][kk])
            if tr is not None:
                tr.set_data(o["x"][max(0, kk - trail_len): kk + 1], o["y"][max(0, kk - trail_len): kk + 1])
        state = f"  {doc['outcome']}" if k == len(t) - 1 else ""
        label.set_text(f"{doc['scenario']}  t = {t[k]:.1f} s{state}")
        return [path_line, robot, *discs, *(tr for tr in trails if tr is not None), label]

    anim = FuncAnimation(fig, frame, frames=len(t), blit=False)
    bar = progress(total=len(t), unit="frame") if progress else None
    drawn = None if bar is None else (lambda i, n: bar.update(1))
    try:
        with atomic_file(path, ".gif") as tmp:
            anim.save(tmp, writer=PillowWriter(fps=fps), progress_callback=drawn)
    finally:
        plt.close(fig)
        if bar is not None:
            bar.close()
