"""The world a robot is tested in: scenario files and their loader, the suites, recorded
pedestrians and walls, the movers, the simulator, the measures and the plots
(docs/architecture.md)."""
from pathlib import Path

from .loader import ScenarioError, load_scenario, scenario_from_dict
from .model import Faults, MovingObstacleSpec, Scenario, Sensing, WalkerSpec
from .random_suite import random_scenario, random_suite
from .suites import CROWD_BEHAVIOURS, CROWD_SUITES, RANDOM_SUITES, SUITES, Suite

__all__ = ["ScenarioError", "load_scenario", "scenario_from_dict", "Scenario", "MovingObstacleSpec", "Sensing",
           "Faults", "SUITES", "RANDOM_SUITES", "CROWD_SUITES", "CROWD_BEHAVIOURS", "Suite", "random_scenario",
           "random_suite", "PAPER_DIR", "paper_scenarios", "WalkerSpec"]

PAPER_DIR = Path(__file__).parent / "paper"
PAPER_NAMES = ("fig7_1_head_on", "fig7_2_crossing", "fig7_3_crossing_off_path")


def paper_scenarios() -> list[Scenario]:
    """The paper's three Fig. 7 situations, in order."""
    return [load_scenario(PAPER_DIR / f"{n}.toml") for n in PAPER_NAMES]
