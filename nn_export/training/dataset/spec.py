"""What decides a dataset's contents: :class:`DatasetSpec`, whose ``spec_id`` every shard
carries, so that a resumed run appends only to shards of the very same request."""
from __future__ import annotations

import hashlib
import json
from dataclasses import asdict, dataclass, field

from casadi_gpc.config import PlannerConfig
from casadi_gpc.robot import RobotParams

from ...runtime.layouts import FeatureLayout
from ..sampler import SamplerSettings

__all__ = ["DATASET_FORMAT", "ARRAY_KEYS", "SCHEMES", "PART_STRIDE", "SHARD_STRIDE", "MIRROR_TOLERANCE_MPS", "DatasetMismatch",
           "DatasetSpec", "digest"]

DATASET_FORMAT = "gpcnav-dataset/1"
ARRAY_KEYS = ("features", "labels", "plan_wheels_mps", "cost", "status", "guess", "iterations", "candidate_costs",
              "solver", "mirror", "situation_id", "sample_id", "mirror_check_mps", "decision_pass")
SCHEMES = ("sampled", "two-pass")
"""How situations are drawn: ``sampled`` (:func:`~nn_export.training.sampler.sample_situation`)
or ``two-pass`` (the paper's two passes, :mod:`nn_export.training.two_pass`)."""
PART_STRIDE = 10 ** 12   # situation ids: part * stride + shard * shard stride + index
SHARD_STRIDE = 10 ** 6
MIRROR_TOLERANCE_MPS = 1e-6


class DatasetMismatch(ValueError):
    """The directory holds a dataset made with other arguments, or is in use."""


@dataclass(frozen=True)
class DatasetSpec:
    """Everything that decides a dataset's contents (its ``spec_id`` is a hash of it)."""

    samples: int
    """Labelled samples wanted, mirror samples included."""
    config: PlannerConfig
    layout: FeatureLayout
    seed: int = 0
    robot: RobotParams = field(default_factory=RobotParams)
    solver: str = "ipopt"
    shard_size: int = 1000
    """Samples per shard (even, so that a situation and its mirror share a shard)."""
    mirror: bool = True
    """Add the mirror image of every situation as a second sample."""
    mirror_check_every: int = 25
    """Solve the mirrored situation for real for every this-many-th situation (0: never)."""
    sampler: SamplerSettings = field(default_factory=SamplerSettings)
    scheme: str = "sampled"
    """How situations are drawn (:data:`SCHEMES`)."""
    tie_margin: float | None = None
    """The near-tie convention's margin (:mod:`nn_export.training.ties`); None: the planner's choice."""

    def __post_init__(self):
        if self.scheme not in SCHEMES:
            raise ValueError(f"scheme must be one of {', '.join(SCHEMES)}, got {self.scheme!r}")
        if self.scheme == "two-pass" and self.layout.name != "paper":
            raise ValueError("the two-pass scheme draws one moving obstacle: it needs the paper layout")
        if self.samples < 1:
            raise ValueError(f"samples must be at least 1, got {self.samples}")
        if self.shard_size < 2 or self.shard_size % 2 or self.shard_size > SHARD_STRIDE:
            raise ValueError(f"shard size must be an even number in [2, {SHARD_STRIDE}], got {self.shard_size}")
        if self.layout.horizon != self.config.horizon:
            raise ValueError(f"layout horizon {self.layout.horizon} != planner horizon {self.config.horizon}")

    @property
    def n_shards(self) -> int:
        return -(-self.samples // self.shard_size)

    def shard_samples(self, index: int) -> int:
        return min(self.shard_size, self.samples - index * self.shard_size)

    def request(self) -> dict:
        """What a resumed run must agree on."""
        return {
            "samples": self.samples, "seed": self.seed, "preset": self.config.name,
            "planner_config": self.config.to_dict(), "feature_layout": self.layout.to_dict(),
            "robot": self.robot.to_dict(), "solver": self.solver, "shard_size": self.shard_size,
            "mirror": self.mirror, "mirror_check_every": self.mirror_check_every, "sampler": asdict(self.sampler),
            # new fields enter only when set, so datasets made before them keep their spec_id
            **({"scheme": self.scheme} if self.scheme != "sampled" else {}),
            **({"tie_margin": self.tie_margin} if self.tie_margin is not None else {}),
        }

    @property
    def spec_id(self) -> str:
        return digest(self.request())



def digest(doc) -> str:
    """A short hash of a JSON-able document (keys sorted)."""
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=str).encode()).hexdigest()[:16]

