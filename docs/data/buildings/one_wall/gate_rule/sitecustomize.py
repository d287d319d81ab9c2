"""Experiment switch: GPCNAV_EXP_WALLS_NEAR_M=X hands the deployed policy's decisions to its walls
network only where a wall segment is within X m of the robot's centre (shipped: the scan's 4 m)."""
import os
import sys

_X = os.environ.get("GPCNAV_EXP_WALLS_NEAR_M")
if _X:
    from nn_export.runtime import side_networks
    from nn_export.runtime.wall_scan import segments_near
    _x = float(_X)
    side_networks.WallsNetwork.near = lambda self, x, y, rows: bool(len(segments_near(rows, x, y, _x)))
    print(f"the walls network within {_x} m of a wall only", file=sys.stderr)
