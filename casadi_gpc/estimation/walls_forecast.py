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

from ..geometry import segment_rows, wall_scan
from ..types import ObstacleForecast

__all__ = ["WallsForecast", "UNION_ID", "walker_features", "MODEL_PATH"]

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


def _frame(past: np.ndarray) -> tuple[float, float]:
    """cos, sin of a walker's frame from its measured positions (oldest first, now last): x
    along its displacement over the last 2 s, the world's x where it moved less than 5 cm."""
    d = past[-1] - past[-5]
    n = float(np.hypot(*d))
    return (1.0, 0.0) if n < 0.05 else (d[0] / n, d[1] / n)


def walker_features(meas: np.ndarray, k: int, j: int, wall_rows, sample_time_s: float = SAMPLE_TIME_S):
    """The network's input for walker ``j`` at sample ``k`` from the measurements ``meas``
    (``(samples, walkers, 2)``, NaN where not measured), in the walker's frame (origin at its
    measured position now): its ``PAST`` previous positions (``2 PAST``), the nearest other
    walkers measured now and at the sample before within ``NEAR_M`` (present, position,
    velocity over the last interval: 5 each, nearest first, zeros for none) and the walls' scan
    from it (``wall_rows``: segments ``(ax, ay, bx, by)``); with the frame's ``(cos, sin)``.
    None without ``PAST + 1`` measured positions."""
    past = meas[k - PAST:k + 1, j]
    if k < PAST or not np.isfinite(past).all():
        return None
    c, s = _frame(past)
    R = np.array([[c, s], [-s, c]])
    now = past[-1]
    own = ((past[:-1] - now) @ R.T).ravel()
    others = []
    here, before = meas[k], meas[k - 1]
    for i in range(meas.shape[1]):
        if i == j or not (np.isfinite(here[i]).all() and np.isfinite(before[i]).all()):
            continue
        rel = here[i] - now
        d = float(np.hypot(*rel))
        if d <= NEAR_M:
            others.append((d, rel @ R.T, (here[i] - before[i]) / sample_time_s @ R.T))
    others.sort(key=lambda o: o[0])
    nb = np.zeros(5 * NEIGHBOURS)
    for n, (_, p, v) in enumerate(others[:NEIGHBOURS]):
        nb[5 * n:5 * n + 5] = (1.0, *p, *v)
    scan = wall_scan(wall_rows, float(now[0]), float(now[1]), math.atan2(s, c), SECTORS, SCAN_M)
    return np.concatenate([own, nb, scan]), c, s


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
        rows, where = [], []
        for n, f in enumerate(forecasts):
            c = col.get(f.obstacle_id)
            ft = None if c is None else walker_features(meas, PAST, c, self._wall_rows)
            if ft is not None:
                rows.append(ft)
                where.append(n)
        if not rows:
            return forecasts
        X = np.array([r[0] for r in rows], dtype=np.float32)
        Y = self.session.run(None, {self._input: X})[0].astype(float)
        out = list(forecasts)
        for (_, c, s), n, y in zip(rows, where, Y):
            f = forecasts[n]
            R = np.array([[c, -s], [s, c]])
            now = meas[PAST, col[f.obstacle_id]]
            means = now + y[:2 * HORIZON].reshape(HORIZON, 2) @ R.T
            out.append(ObstacleForecast(f.obstacle_id + UNION_ID, f.radius_m, means, np.asarray(f.covs_m2)))
        if counters is not None:
            counters["walls_forecasts"] = counters.get("walls_forecasts", 0) + len(rows)
        return out
