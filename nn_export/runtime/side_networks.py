"""The networks that answer in place of a policy's main model where its layout cannot hold the
situation (numpy and onnxruntime only): the crowd network (``set`` layout), where more obstacles
are in range than the main model has slots for, and the walls network (``set-walls``), where a
wall of the map is within its scan's range. :class:`~nn_export.runtime.policy.OnnxPolicy` holds
them beside its main model; its tracker feeds them all."""
from __future__ import annotations

import hashlib
import math
from pathlib import Path

import numpy as np

from casadi_gpc.robot import RobotParams

from .layouts import FeatureLayout
from .model_file import INPUT_NAME, _bind, _load_session, _validate, read_model_metadata
from .wall_scan import segments_near

__all__ = ["CrowdNetwork", "WallsNetwork"]


class CrowdNetwork:
    """A second network, of the ``set`` layout, for the situations the main model's layout
    cannot hold: more moving obstacles in range than its moving slots, or static obstacles
    beyond its static slots. The same checks at load as the main model, one pass, its own
    bound buffers; the policy's tracker feeds both."""

    role = "crowd"

    def __init__(self, path: Path, preset: str, robot: RobotParams, main: FeatureLayout, compiled: bool = False):
        self.session, data = _load_session(path)
        meta = read_model_metadata(self.session, path)
        self.layout, _, self.steps = _validate(path, self.session, meta, preset, robot)
        if not self.layout.is_set or self.layout.horizon != main.horizon:
            raise ValueError(f"{path}: a {self.role} network must have a set layout and horizon {main.horizon} "
                             f"(it has {self.layout.name!r}, H={self.layout.horizon})")
        if self.role == "walls" and not self.layout.wall_sectors:
            raise ValueError(f"{path}: a walls network must read walls (layout set-walls, not {self.layout.name!r})")
        if meta.get("decision_passes", "2") != "1":
            raise ValueError(f"{path}: a {self.role} network runs one pass (export it with --passes 1)")
        self.main_slots = (main.k_moving, main.k_static, main.range_m)
        self._x, self._y, self._write, self._binding, self._run = _bind(self.session, self.layout.size, path,
                                                                        2 * self.steps)
        # its one-command pass compiled where that answers as onnxruntime does (compiled_set)
        if not compiled or self.steps > 1:
            self._compiled, executor = None, "onnxruntime" + (" (a plan network)" if self.steps > 1 else "")
        else:  # (imported here: compiling it at import would cost every policy that does not ask for it)
            from .compiled_set import compile_set_network
            self._compiled, executor = compile_set_network(
                data, self.layout.size, self.layout.set_slots, lambda X: self.session.run(None, {INPUT_NAME: X})[0])
        self.info = {"path": str(path), "bytes": len(data), "sha256": hashlib.sha256(data).hexdigest(),
                     "feature_layout": self.layout.name, "n_features": self.layout.size,
                     "validation_rmse_mps": float(meta["validation_rmse_mps"]), "executor": executor}

    def needed(self, x: float, y: float, tracks, statics) -> bool:
        """Whether the main layout would drop an obstacle in range of the robot at ``(x, y)``."""
        k_moving, k_static, rng = self.main_slots
        hypot = math.hypot
        if len(tracks) > k_moving:
            n = 0
            for t in tracks:
                sv = t.state_values
                n += hypot(sv[0] - x, sv[1] - y) <= rng
            if n > k_moving:
                return True
        if len(statics) > k_static:
            n = sum(hypot(st.position_m[0] - x, st.position_m[1] - y) <= rng for st in statics)
            return n > k_static
        return False

    def answer(self, values: list[float]) -> tuple[float, float]:
        self._write(*values)
        if self._compiled is not None:
            return self._compiled.answer(self._x[0])
        self._run()
        vr, vl = self._y[0, :2].tolist()
        return vr, vl

    def plan(self, values: list[float]) -> np.ndarray:
        """The network's (steps, 2) wheel speeds on these feature values, float64."""
        self._write(*values)
        self._run()
        return self._y.reshape(self.steps, 2).astype(float)


class WallsNetwork(CrowdNetwork):
    """A third network, of the ``set-walls`` layout, that answers wherever a wall is within its
    scan's range of the robot (the other two read no walls): the same checks at load, one pass,
    its own buffers, the same tracker."""

    role = "walls"

    def near(self, x: float, y: float, wall_rows: np.ndarray) -> bool:
        """Whether a wall segment is within the scan's range of the robot at ``(x, y)``."""
        return bool(len(segments_near(wall_rows, x, y, self.layout.wall_range_m)))
