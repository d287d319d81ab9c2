"""The paper's obstacle EKF as a predictor of real people: ADE and FDE over 4.8 s.

The prediction literature's standard (Alahi et al. 2016; Gupta et al. 2018; Schöller et
al. 2020): every window of 20 consecutive rows of one person, 0.4 s apart (8 observed,
3.2 s; 12 predicted, 4.8 s); ADE is the mean distance between predicted and recorded
positions over the 12, FDE the distance at the last. Each recording is read as
``gpcnav import-tracks`` reads it (frame time per video); only the track pieces with rows
exactly 0.4 s apart enter (the literature's windows).

Predictors, on the same windows:

- ``ekf``: :class:`casadi_gpc.estimation.ObstacleEKF` at T = 0.4 s (the planner's filter,
  its settings scaled to the sample time as the check layer scales them), fed the 8
  recorded positions as measurements, then its 12-step prediction (the mean);
- ``ekf straight``: the same filter, its prediction at the estimated speed and heading
  (the ``improved`` planner's forecast, ``PlannerConfig.forecast = "straight"``);
- ``cv``: the constant-velocity model of Schöller et al.: the last observed displacement
  repeated.

The published figure beside them: Schöller et al.'s constant-velocity model averaged over
the five ETH/UCY scenes (ETH, Hotel, Univ, Zara1, Zara2), ADE / FDE 0.39 / 0.83 m, as its
authors' repository gives it after their fix of the data loading
(``cschoeller/constant_velocity_pedestrian_motion``, README; the paper's Table 1 reports
the figures before that fix). It is an average over other files (Univ is students001 and
students003), so it sits beside the rows, not in them.

Beside the errors, whether the forecast knows how wrong it is: the share of recorded
positions within two standard deviations of the straight forecast (along the worst
direction, as the planner's clearance margin and the check layer widen by them) at 1.2, 2.0
and 4.8 s; a calibrated Gaussian forecast holds 0.86 (as wide in every direction) to 0.95
(long and thin) there. ``--speed-noise`` and
``--heading-noise`` set the filter's two process noises (``EKFSettings``) to see what a
filter tuned to people would claim.

Usage: ``python tools/forecast_accuracy.py [RECORDING ...] [--out docs/data/pedestrians/forecast_accuracy.json]
[--speed-noise A --heading-noise B]`` (default: the three shipped UCY recordings). Prints a
Markdown table.
"""
from __future__ import annotations

import argparse
import sys
from dataclasses import asdict, replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))
from casadi_gpc.estimation import EKFSettings, ObstacleEKF, worst_std_m  # noqa: E402
from scenarios.recordings import RECORDINGS_DIR, SHIPPED, read_recording  # noqa: E402

OBSERVED, PREDICTED, STEP_S = 8, 12, 0.4


def windows(rec):
    """Every (20, 2) window of consecutive rows 0.4 s apart, per person."""
    for tr in rec.tracks:
        ok = np.abs(np.diff(tr[:, 0]) - STEP_S) < 1e-6
        start = 0
        for k in range(len(ok) + 1):
            if k == len(ok) or not ok[k]:
                piece = tr[start:k + 1, 1:]
                for s in range(len(piece) - OBSERVED - PREDICTED + 1):
                    yield piece[s:s + OBSERVED + PREDICTED]
                start = k + 1


SETTINGS = EKFSettings()
"""The filter's noise levels (``--speed-noise`` and ``--heading-noise`` replace two of them)."""
COVERAGE_STEPS = (3, 5, 12)
"""The predicted steps (1.2, 2.0 and 4.8 s ahead) at which the forecast's uncertainty is
checked against the recording."""


def _filtered(obs: np.ndarray) -> ObstacleEKF:
    ekf = ObstacleEKF(STEP_S, SETTINGS.for_sample_time(STEP_S))
    for z in obs:
        ekf.step(z)
    return ekf


def predict_ekf(obs: np.ndarray) -> np.ndarray:
    means, _ = _filtered(obs).predict(PREDICTED)
    return np.asarray(means)[:, :2]


def predict_ekf_straight(obs: np.ndarray) -> np.ndarray:
    means, _ = _filtered(obs).predict(PREDICTED, straight=True)
    return np.asarray(means)[:, :2]


def coverage(rec) -> list[float]:
    """The share of the recorded positions within two standard deviations (along the worst
    direction, as the planner's margin and the check widen by them) of the straight
    forecast, at each of :data:`COVERAGE_STEPS`: 0.86 to 0.95 for a calibrated Gaussian one."""
    inside = []
    for w in windows(rec):
        means, covs = _filtered(w[:OBSERVED]).predict(PREDICTED, straight=True)
        d = np.hypot(*(np.asarray(means)[:, :2] - w[OBSERVED:]).T)
        inside.append(d <= 2.0 * worst_std_m(np.asarray(covs)[:, :2, :2]))
    share = np.mean(inside, axis=0)
    return [float(share[k - 1]) for k in COVERAGE_STEPS]


PUBLISHED_CV = {"ade_m": 0.39, "fde_m": 0.83, "source": "Schöller et al. 2020, constant-velocity model, mean of "
                "ETH, Hotel, Univ, Zara1, Zara2 (cschoeller/constant_velocity_pedestrian_motion, README)"}


def predict_cv(obs: np.ndarray) -> np.ndarray:
    v = obs[-1] - obs[-2]
    return obs[-1] + v * np.arange(1, PREDICTED + 1)[:, None]


def errors(rec, predictor) -> tuple[float, float, int]:
    ade, fde = [], []
    for w in windows(rec):
        p = predictor(w[:OBSERVED])
        d = np.hypot(*(p - w[OBSERVED:]).T)
        ade.append(d.mean())
        fde.append(d[-1])
    return float(np.mean(ade)), float(np.mean(fde)), len(ade)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recordings", nargs="*", type=Path)
    ap.add_argument("--out", type=Path, default=None)
    ap.add_argument("--speed-noise", type=float, default=None,
                    help="the filter's speed noise, m/s^2 (default: the planner's, EKFSettings)")
    ap.add_argument("--heading-noise", type=float, default=None,
                    help="the filter's heading noise, rad per step (default: the planner's)")
    args = ap.parse_args(argv)
    global SETTINGS
    for name, value in (("speed_noise_mps2", args.speed_noise), ("heading_noise_rad", args.heading_noise)):
        if value is not None:
            if not (np.isfinite(value) and value >= 0):
                ap.error(f"--{name.split('_')[0]}-noise must be finite and not negative, got {value}")
            SETTINGS = replace(SETTINGS, **{name: value})
    paths = args.recordings or [RECORDINGS_DIR / f"{n}.txt.gz" for n in SHIPPED]
    rows = []
    for path in paths:
        rec = read_recording(path)
        if next(windows(rec), None) is None:
            print(f"{rec.name}: no window of 20 rows 0.4 s apart (rows {rec.seconds_per_frame * 10:.3f} s apart); "
                  "left out", file=sys.stderr)
            continue
        (ea, ef, n), (sa, sf, _), (ca, cf, _) = (errors(rec, predict_ekf), errors(rec, predict_ekf_straight),
                                                 errors(rec, predict_cv))
        rows.append({"recording": rec.name, "windows": n, "ekf": {"ade_m": ea, "fde_m": ef},
                     "ekf_straight": {"ade_m": sa, "fde_m": sf, "within_2_sigma": dict(zip(
                         (f"{k * STEP_S:.1f}s" for k in COVERAGE_STEPS), coverage(rec)))},
                     "cv": {"ade_m": ca, "fde_m": cf}})
    print("| recording | windows | EKF (the paper's, turning) ADE / FDE m | EKF straight (`improved`) | "
          "recorded within 2 sigma of the straight forecast at 1.2 / 2.0 / 4.8 s | constant velocity ADE / FDE m |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        cover = " / ".join(f"{v:.2f}" for v in r["ekf_straight"]["within_2_sigma"].values())
        print(f"| {r['recording']} | {r['windows']} | {r['ekf']['ade_m']:.3f} / {r['ekf']['fde_m']:.3f} | "
              f"{r['ekf_straight']['ade_m']:.3f} / {r['ekf_straight']['fde_m']:.3f} | {cover} | "
              f"{r['cv']['ade_m']:.3f} / {r['cv']['fde_m']:.3f} |")
    print(f"| published (five scenes) | | | | | {PUBLISHED_CV['ade_m']:.2f} / {PUBLISHED_CV['fde_m']:.2f} |")
    if args.out:
        from casadi_gpc.io import write_json
        write_json(args.out, {"observed": OBSERVED, "predicted": PREDICTED, "step_s": STEP_S, "rows": rows,
                              "filter_settings": asdict(SETTINGS),
                              "published_cv": PUBLISHED_CV})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
