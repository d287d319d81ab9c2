"""A second forecast of each walker near walls, learned from walkers in buildings (numpy and
onnxruntime).

The filter forecasts a walker straight on at its estimated speed and heading. Among walls
that is where it errs most: a walker turns round a corner, follows a corridor, makes way for
another at a door, and the robot standing in its way is walked into (docs/buildings.md,
"Told the walkers' future": told the truth, the same planner and check have no collision in
600 episodes of the three wall suites). The network shipped here
(``casadi_gpc/models/walls-forecast.onnx``) was trained on the walkers of those suites
(ORCA and social force, blind to the robot, seeds 500-799, none the evaluations use; recipe
in docs/data/pedestrians/learned_forecast/: ``data.py`` makes the samples, ``train.py`` the
network): from a walker's last 8 measured positions, its 8 nearest neighbours within 6 m and
a 16-sector scan of the walls to 4 m around it, its positions 0.5 to 6 s ahead.

It does not replace the filter's forecast, it joins it: each walker measured at the last 9
samples is handed to the planner and its check twice, the filter's forecast and, as a second
mover (its id + :data:`UNION_ID`), the learned means with the filter's covariances. The plan
and the check avoid both: where the walker goes on as now, and where walkers like it went.
Alone the learned forecast drove into people who see the robot (they give way, the walkers it
was trained on did not); with both, judged by a rule on cases nothing had run (seed 44 of the
wall suites, navground's corridor 6901-7000: collisions 5 -> 1, none with the robot
approaching, goals 677 -> 677; docs/data/pedestrians/learned_forecast/union/rule.md).
Only in a scene whose map has walls, and only for the sample time and horizon it was trained
at (:meth:`WallsForecast.for_config`).
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from ..geometry import segment_rows, wall_scans
from ..types import ObstacleForecast

__all__ = ["WallsForecast", "UNION_ID", "walker_features", "MODEL_PATH", "N_INPUTS"]

MODEL_PATH = Path(__file__).resolve().parents[1] / "models" / "walls-forecast.onnx"
"""The shipped network."""
SAMPLE_TIME_S, HORIZON = 0.5, 12
"""The sample time and horizon the network was trained at: 12 positions 0.5 s apart."""
PAST, NEIGHBOURS, NEAR_M, SECTORS, SCAN_M = 8, 8, 6.0, 16, 4.0
"""Its inputs: the last ``PAST`` measured positions before now, the ``NEIGHBOURS`` nearest
other walkers within ``NEAR_M``, a scan of ``SECTORS`` sectors to ``SCAN_M``."""
N_INPUTS = 2 * PAST + 5 * NEIGHBOURS + SECTORS
UNION_ID = 10_000_000
"""Added to a walker's id for its second, learned, forecast."""


def walker_features(meas: np.ndarray, cols, wall_rows, sample_time_s: float = SAMPLE_TIME_S):
    """The network's inputs for the walkers ``cols`` (columns of ``meas``) at the last sample of
    the measurements ``meas`` (``(PAST + 1, walkers, 2)``, oldest first, NaN where not
    measured), each in its own frame: origin at its measured position now, x along its
    displacement over the last 2 s (the world's x where it moved less than 5 cm). Per walker: its
    ``PAST`` previous positions (``2 PAST``), the nearest other walkers measured now and at the
    sample before within ``NEAR_M`` (present, position, velocity over the last interval: 5
    each, nearest first, zeros for none) and the walls' scan from it (``wall_rows``: segments
    ``(ax, ay, bx, by)``). Returns ``(X, cos, sin)``: ``(m, N_INPUTS)`` and the frames, for the
    walkers of ``cols`` measured at every one of the ``PAST + 1`` samples (``m`` of them, in
    their order), and those columns."""
    cols = [j for j in cols if np.isfinite(meas[:, j]).all()]
    m = len(cols)
    if not m:
        return np.zeros((0, N_INPUTS)), np.zeros(0), np.zeros(0), cols
    past = meas[:, cols]                                                      # (PAST + 1, m, 2)
    now = past[-1]
    d = now - past[-5]
    norm = np.hypot(d[:, 0], d[:, 1])
    still = norm < 0.05
    with np.errstate(divide="ignore", invalid="ignore"):
        c = np.where(still, 1.0, d[:, 0] / norm)
        s = np.where(still, 0.0, d[:, 1] / norm)
    X = np.zeros((m, N_INPUTS))
    rel = past[:-1] - now                                                     # (PAST, m, 2)
    X[:, 0:2 * PAST:2] = (rel[..., 0] * c + rel[..., 1] * s).T
    X[:, 1:2 * PAST:2] = (-rel[..., 0] * s + rel[..., 1] * c).T
    here, before = meas[-1], meas[-2]
    seen = np.isfinite(here).all(1) & np.isfinite(before).all(1)
    vel = (here - before) / sample_time_s
    # every walker's nearest others, stably by distance (ties in column order), at once
    dx, dy = here[None, :, 0] - now[:, None, 0], here[None, :, 1] - now[:, None, 1]      # (m, walkers)
    dist = np.hypot(dx, dy)
    near = seen[None, :] & (dist <= NEAR_M)
    near[np.arange(m), cols] = False
    order = np.argsort(np.where(near, dist, np.inf), axis=1, kind="stable")[:, :NEIGHBOURS]
    chosen = np.take_along_axis(near, order, axis=1)                                       # (m, k)
    px, py = np.take_along_axis(dx, order, axis=1), np.take_along_axis(dy, order, axis=1)
    vx, vy = vel[order, 0], vel[order, 1]
    cc, ss = c[:, None], s[:, None]
    block = np.stack([np.ones_like(px), px * cc + py * ss, -px * ss + py * cc, vx * cc + vy * ss,
                      -vx * ss + vy * cc], axis=-1)
    block[~chosen] = 0.0
    X[:, 2 * PAST:2 * PAST + 5 * order.shape[1]] = block.reshape(m, -1)
    # the heading as the scan takes it (its cosine and sine again, as one point's scan makes them)
    heads = [math.atan2(sr, cr) for cr, sr in zip(c.tolist(), s.tolist())]
    X[:, 2 * PAST + 5 * NEIGHBOURS:] = wall_scans(wall_rows, now[:, 0].copy(), now[:, 1].copy(),
                                                  np.array([math.cos(h) for h in heads]),
                                                  np.array([math.sin(h) for h in heads]), SECTORS, SCAN_M)
    return X, c, s, cols


class WallsForecast:
    """The walkers' measured positions of the last ``PAST + 1`` samples, and their learned
    forecasts added beside the filter's (module docstring). :meth:`reset` at an episode's
    start; :meth:`add` once per sample in a scene with walls."""

    def __init__(self, path: Path | str = MODEL_PATH):
        import onnxruntime as ort
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = opts.inter_op_num_threads = 1
        opts.log_severity_level = 3
        try:
            self.session = ort.InferenceSession(str(path), opts, providers=["CPUExecutionProvider"])
        except Exception as exc:  # onnxruntime raises its own classes for a missing or corrupt file
            raise ValueError(f"{path}: not a readable walker forecast ({str(exc).splitlines()[0]})") from None
        inp, out = self.session.get_inputs()[0], self.session.get_outputs()[0]
        if inp.shape[1:] != [N_INPUTS] or out.shape[1:] != [3 * HORIZON]:
            raise ValueError(f"{path}: a walker forecast takes {N_INPUTS} inputs and gives {3 * HORIZON} outputs "
                             f"(this one {inp.shape[1:]} and {out.shape[1:]})")
        self._input = inp.name
        self.reset()

    @staticmethod
    def for_config(config) -> "WallsForecast | None":
        """The shipped forecast where ``config`` asks for it (``walls_forecast``) at the sample
        time and horizon it was trained at; None otherwise."""
        if not getattr(config, "walls_forecast", False):
            return None
        if abs(config.sample_time_s - SAMPLE_TIME_S) > 1e-9 or config.horizon != HORIZON:
            return None
        return WallsForecast()

    def reset(self) -> None:
        self._history: dict[int, dict[int, tuple[float, float]]] = {}  # id -> {sample: (x, y)}
        self._walls_key, self._wall_rows = None, None

    def add(self, obs, forecasts: list, counters: dict | None = None) -> list:
        """``forecasts`` (the filter's, one per tracked walker) with the learned one of each
        walker measured at the last ``PAST + 1`` samples appended, as a second mover with the
        same radius and the filter's covariances; the measurements of ``obs`` kept. Where the
        map of ``obs`` has no walls, ``forecasts`` as they are. Counted in ``counters``
        (``walls_forecasts``: the second movers added)."""
        k = int(round(obs.t_s / SAMPLE_TIME_S))
        hist = self._history
        for m in obs.moving:
            p = m.position_m
            if p is not None and all(np.isfinite(p)):
                h = hist.setdefault(m.obstacle_id, {})
                h[k] = (float(p[0]), float(p[1]))
                for old in [s for s in h if s < k - PAST]:
                    del h[old]
        for i in [i for i, h in hist.items() if max(h) < k - PAST]:  # long gone
            del hist[i]
        if not obs.walls or not forecasts:
            return forecasts
        if obs.walls is not self._walls_key:  # the map's segments, made again only when it changes
            self._walls_key, self._wall_rows = obs.walls, segment_rows(obs.walls)
        ids = sorted(hist)
        meas = np.full((PAST + 1, len(ids), 2), np.nan)
        for c, i in enumerate(ids):
            for s, p in hist[i].items():
                if s >= k - PAST:  # a walker not measured now keeps older rows
                    meas[s - (k - PAST), c] = p
        col = {i: c for c, i in enumerate(ids)}
        where = [n for n, f in enumerate(forecasts) if f.obstacle_id in col]
        X, cos, sin, cols = walker_features(meas, [col[forecasts[n].obstacle_id] for n in where], self._wall_rows)
        if not cols:
            return forecasts
        kept = set(cols)
        where = [n for n in where if col[forecasts[n].obstacle_id] in kept]
        Y = self.session.run(None, {self._input: X.astype(np.float32)})[0].astype(float)
        out = list(forecasts)
        for n, j, c, s, y in zip(where, cols, cos.tolist(), sin.tolist(), Y):
            f = forecasts[n]
            R = np.array([[c, -s], [s, c]])
            means = meas[PAST, j] + y[:2 * HORIZON].reshape(HORIZON, 2) @ R.T
            out.append(ObstacleForecast(f.obstacle_id + UNION_ID, f.radius_m, means, np.asarray(f.covs_m2)))
        if counters is not None:
            counters["walls_forecasts"] = counters.get("walls_forecasts", 0) + len(cols)
        return out
