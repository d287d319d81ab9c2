import sys, time, timeit, numpy as np
from gpcnav.controllers import make, ControllerSpec
from casadi_gpc.config import preset
from scenarios.suites import Suite
from scenarios.simulator import simulate
import casadi_gpc.safety.screen as SC
from casadi_gpc.safety.obstacles import forecast_arrays
sc = Suite("circle-crossing", 1, 1, 10, "orca").scenario(0)
cfg = preset("improved")
pol = make(ControllerSpec("nn"), cfg, sc.robot)
calls = []
flt = pol.filter
orig = flt._quick
def q(*a, **k):
    calls.append((a, k)); return orig(*a, **k)
flt._quick = q
simulate(sc, pol, "nn")
flt._quick = orig
print(len(calls))
a, k = calls[15]
robot, wheels, forecasts, statics = a[:4]
print(type(wheels), len(forecasts))
N = 2000
def t(f): 
    return min(timeit.repeat(f, number=N, repeat=5)) / N * 1e6
flt._screen_memo = None
print("quick total", t(lambda: (setattr(flt, "_screen_memo", None), orig(*a, **k))))
print("forecast_arrays", t(lambda: forecast_arrays(forecasts)))
print("obstacle arrays", t(lambda: flt._quick_obstacle_arrays(forecasts, statics)))
obs = flt._quick_obstacle_arrays(forecasts, statics)
H = flt.horizon
reach = [0.1*i for i in range(1, H+1)]
print("reach_bound", t(lambda: SC._reach_bound_arrays(complex(robot.x_m, robot.y_m), obs, reach)))
cmd = wheels
path = flt._then_target(cmd, flt._reverse_target)
print("then_target", t(lambda: flt._then_target(cmd, flt._reverse_target)))
T, W = flt.sample_time_s, flt.robot.wheel_base_m
P = np.array(path, dtype=float).reshape(1, H, 2)
print("escape_bounds reverse", t(lambda: SC.escape_bounds(float(robot.x_m), float(robot.y_m), float(robot.heading_rad), P, T, W, T*T/16/W, obs[0], obs[1], SC._NO_WALLS, 0.35)))
E = flt._escapes(np.array(cmd, dtype=float))
print("escapes", E.shape, t(lambda: flt._escapes(np.array(cmd, dtype=float))))
print("escape_bounds manoeuvres", t(lambda: SC.escape_bounds(float(robot.x_m), float(robot.y_m), float(robot.heading_rad), E, T, W, T*T/16/W, obs[0], obs[1], SC._NO_WALLS, 0.35)))
print("quick_escapes", t(lambda: flt._quick_escapes(robot, cmd, obs, None, False, forecasts, statics)))
