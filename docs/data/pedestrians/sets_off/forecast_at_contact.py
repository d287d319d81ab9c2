"""For each given episode of a suite, simulated again with the GPC (one process, one solve
lane): when it collides, how far the colliding mover's forecast was from where the mover
touched the robot. The forecasts are the decisions' at the last sample at least 0.5, 1, 1.5
and 2 s before the contact, their means interpolated to the contact's time (the track's or
its ghost's, the nearer).

    python forecast_at_contact.py doorway 5 orca 1 46,85,133     # suite, movers, behaviour, seed, episodes
    python forecast_at_contact.py corner 5 orca 1 66,82,116,117,137
    python forecast_at_contact.py corridor 5 orca 1 152
"""
import sys, numpy as np
from scenarios import Suite
from gpcnav.controllers import ControllerSpec, make
from casadi_gpc.config import preset
from scenarios.simulator import simulate
suite, movers, beh, seed = sys.argv[1], int(sys.argv[2]), sys.argv[3], int(sys.argv[4])
for idx in map(int, sys.argv[5].split(",")):
    sc = Suite(suite, 200, seed, movers, beh).scenario(idx)
    cfg = preset("improved").for_walls(bool(sc.walls)).with_overrides(solve_lanes=1)
    log = simulate(sc, make(ControllerSpec("gpc"), cfg, sc.robot), "gpc")
    if not log.collision:
        print(sc.name, log.outcome); continue
    k, tc = log.collision["index"], log.collision["time_s"]
    T = np.array(log.t)
    j_c = int(np.argmin(abs(T - tc)))
    true_c = np.asarray(log.obstacle_xy[j_c])[k]
    errs = []
    for back in (0.5, 1.0, 1.5, 2.0):
        ts = np.floor((tc - back) / 0.5) * 0.5  # the last sample at least `back` before the contact
        d = log.decisions[int(np.argmin(abs(T - ts)))]
        fs = [f for f in (d.forecasts or []) if f.obstacle_id == k]
        if not fs:
            errs.append("none")
            continue
        a = (tc - ts) / 0.5 - 1  # the contact's time in forecast steps (step n is at ts + 0.5 (n + 1))
        n = min(int(np.floor(a)), len(fs[0].means_m) - 2)
        w = a - n
        e = min(np.hypot(*((1 - w) * np.asarray(f.means_m)[n] + w * np.asarray(f.means_m)[n + 1] - true_c))
                for f in fs)
        errs.append(f"{e:.2f}")
    print(sc.name, f"t={tc:.2f} speed_towards {log.collision['robot_speed_towards_mps']:.2f} forecast error at "
          "contact, made 0.5/1/1.5/2 s before:", errs)
