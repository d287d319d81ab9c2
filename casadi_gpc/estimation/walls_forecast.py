"""A second forecast of each walker near walls, learned from walkers in buildings (numpy, numba
and onnxruntime).

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
from numba import njit

from ..geometry import map_segment_rows, wall_scans
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
    ``(ax, ay, bx, by)``). Returns ``(X, cos, sin, kept)``: ``(m, N_INPUTS)``, the frames, and
    the columns of ``cols`` measured at every one of the ``PAST + 1`` samples (``m`` of them, in
    their order), whose rows these are. Within 1e-12 of the prototype's features (its rotations
    were a matrix product; tested)."""
    cols = [j for j, ok in zip(cols, np.isfinite(meas[:, cols]).all(axis=(0, 2)).tolist()) if ok]
    m = len(cols)
    if not m:
        return np.zeros((0, N_INPUTS)), np.zeros(0), np.zeros(0), cols
    past = np.ascontiguousarray(meas[:, cols])                                # (PAST + 1, m, 2)
    X, c, s = np.zeros((m, N_INPUTS)), np.empty(m), np.empty(m)
    _features_kernel(past, np.ascontiguousarray(meas[-1]), np.ascontiguousarray(meas[-2]),
                     np.array(cols, dtype=np.int64), float(sample_time_s), NEAR_M, X, c, s)
    now = past[-1]
    # the heading as the scan takes it (its cosine and sine again, as one point's scan makes them)
    heads = [math.atan2(sr, cr) for cr, sr in zip(c.tolist(), s.tolist())]
    X[:, 2 * PAST + 5 * NEIGHBOURS:] = wall_scans(wall_rows, now[:, 0], now[:, 1],
                                                  np.array([math.cos(h) for h in heads]),
                                                  np.array([math.sin(h) for h in heads]), SECTORS, SCAN_M)
    return X, c, s, cols


_SESSIONS: dict[str, tuple] = {}
"""The loaded networks by file (one onnxruntime session a process, however many planners)."""


def _session(path: Path | str) -> tuple:
    """The onnxruntime session of the network in ``path`` and its input's name, loaded and checked
    once a process; a missing, corrupt or misshapen file a ``ValueError`` in one line."""
    key = str(Path(path).resolve())
    if key not in _SESSIONS:
        import onnxruntime as ort
        opts = ort.SessionOptions()
        opts.intra_op_num_threads = opts.inter_op_num_threads = 1
        opts.log_severity_level = 3
        try:
            session = ort.InferenceSession(key, opts, providers=["CPUExecutionProvider"])
        except Exception as exc:  # onnxruntime raises its own classes for a missing or corrupt file
            raise ValueError(f"{path}: not a readable walker forecast ({str(exc).splitlines()[0]})") from None
        inp, out = session.get_inputs()[0], session.get_outputs()[0]
        if inp.shape[1:] != [N_INPUTS] or out.shape[1:] != [3 * HORIZON]:
            raise ValueError(f"{path}: a walker forecast takes {N_INPUTS} inputs and gives {3 * HORIZON} outputs "
                             f"(this one {inp.shape[1:]} and {out.shape[1:]})")
        _SESSIONS[key] = (session, inp.name)
    return _SESSIONS[key]


class WallsForecast:
    """The walkers' measured positions of the last ``PAST + 1`` samples, and their learned
    forecasts added beside the filter's (module docstring). :meth:`reset` at an episode's
    start; :meth:`add` once per sample in a scene with walls."""

    def __init__(self, path: Path | str = MODEL_PATH):
        self.session, self._input = _session(path)
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
        # the measured positions of the last PAST + 1 samples, oldest row first, a column per walker
        self._buf = np.full((PAST + 1, 16, 2), np.nan)
        self._col: dict[int, int] = {}  # walker id -> its column
        self._seen: dict[int, int] = {}  # walker id -> the last sample it was measured at
        self._free: list[int] = list(range(16))[::-1]  # the buffer's free columns, the lowest last
        self._k: int | None = None

    def _keep(self, obs) -> int:
        """Move the buffer on to this sample and write its measurements; the sample's index."""
        k = int(round(obs.t_s / SAMPLE_TIME_S))
        buf = self._buf
        shift = 0 if self._k is None else k - self._k
        if shift < 0:  # time went back: a new episode without reset()
            self.reset()
            return self._keep(obs)
        if shift > PAST:  # nothing left of the window
            buf[:] = np.nan
        elif shift:
            buf[:-shift] = buf[shift:]
            buf[-shift:] = np.nan
        self._k = k
        col, seen = self._col, self._seen
        for m in obs.moving:
            p = m.position_m
            if p is not None and math.isfinite(p[0]) and math.isfinite(p[1]):
                c = col.get(m.obstacle_id)
                if c is None:
                    if not self._free:  # room for twice as many
                        self._free = list(range(buf.shape[1], 2 * buf.shape[1]))[::-1]
                        self._buf = buf = np.concatenate((buf, np.full_like(buf, np.nan)), axis=1)
                    c = col[m.obstacle_id] = self._free.pop()
                buf[-1, c] = (float(p[0]), float(p[1]))
                seen[m.obstacle_id] = k
        for i in [i for i, s in seen.items() if s < k - PAST]:  # long gone: its column free again
            c = col.pop(i)
            del seen[i]
            buf[:, c] = np.nan
            self._free.append(c)
        return k

    def add(self, obs, forecasts: list, counters: dict | None = None) -> list:
        """``forecasts`` (the filter's, one per tracked walker) with the learned one of each
        walker measured at the last ``PAST + 1`` samples appended, as a second mover with the
        same radius and the filter's covariances; the measurements of ``obs`` kept. Where the
        map of ``obs`` has no walls, ``forecasts`` as they are. Counted in ``counters``
        (``walls_forecasts``: the second movers added)."""
        self._keep(obs)
        if not obs.walls or not forecasts:
            return forecasts
        ids = sorted(self._col)  # the walkers in the order of their ids (the neighbours' ties)
        meas = self._buf[:, [self._col[i] for i in ids]]
        col = {i: c for c, i in enumerate(ids)}
        where = [n for n, f in enumerate(forecasts) if f.obstacle_id in col]
        X, cos, sin, cols = walker_features(meas, [col[forecasts[n].obstacle_id] for n in where],
                                            map_segment_rows(obs.walls))  # the map's one array, made once
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


@njit("void(float64[:, :, ::1], float64[:, ::1], float64[:, ::1], int64[::1], float64, float64, float64[:, ::1], "
      "float64[::1], float64[::1])", cache=True)
def _features_kernel(past, here, before, cols, T, near_m, X, c_out, s_out):  # pragma: no cover - compiled
    """:func:`walker_features` but the scan, walker by walker: the frame, the past positions in it,
    and the nearest others (stably by distance, ties in column order)."""
    P = past.shape[0] - 1
    K = (X.shape[1] - 2 * P) // 5
    for r in range(past.shape[1]):
        j = cols[r]
        n0, n1 = past[P, r, 0], past[P, r, 1]
        d0, d1 = n0 - past[P - 4, r, 0], n1 - past[P - 4, r, 1]
        norm = np.hypot(d0, d1)
        if norm < 0.05:
            c, s = 1.0, 0.0
        else:
            c, s = d0 / norm, d1 / norm
        c_out[r], s_out[r] = c, s
        for q in range(P):
            rx, ry = past[q, r, 0] - n0, past[q, r, 1] - n1
            X[r, 2 * q] = rx * c + ry * s
            X[r, 2 * q + 1] = -rx * s + ry * c
        # the others measured now and at the sample before, within reach
        taken = np.zeros(here.shape[0], dtype=np.bool_)
        dist = np.full(here.shape[0], np.inf)
        for i in range(here.shape[0]):
            if i == j or not (np.isfinite(here[i, 0]) and np.isfinite(here[i, 1]) and np.isfinite(before[i, 0])
                              and np.isfinite(before[i, 1])):
                continue
            e = np.hypot(here[i, 0] - n0, here[i, 1] - n1)
            if e <= near_m:
                dist[i] = e
        for q in range(K):
            best = -1
            for i in range(here.shape[0]):
                if not taken[i] and dist[i] < np.inf and (best < 0 or dist[i] < dist[best]):
                    best = i
            if best < 0:
                break
            taken[best] = True
            px, py = here[best, 0] - n0, here[best, 1] - n1
            vx, vy = (here[best, 0] - before[best, 0]) / T, (here[best, 1] - before[best, 1]) / T
            o = 2 * P + 5 * q
            X[r, o] = 1.0
            X[r, o + 1], X[r, o + 2] = px * c + py * s, -px * s + py * c
            X[r, o + 3], X[r, o + 4] = vx * c + vy * s, -vx * s + vy * c
