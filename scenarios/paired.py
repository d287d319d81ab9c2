"""Two runs of the same episodes compared episode by episode: for reaching the goal and for
colliding, how many episodes gained the outcome and how many lost it, and the exact two-sided
sign test of that split (McNemar's test in its exact form).

Most episodes end the same way in both runs; the ones that changed tell the two apart. Were a
change equally likely either way, the sign test gives the chance of a split at least as
uneven. (In navground's corridor a small change to the GPC's check moves a quarter of the
outcomes each way: totals there are decided by that noise; docs/buildings.md.)"""
from __future__ import annotations

from scipy.stats import binomtest

__all__ = ["PAIRED_OUTCOMES", "outcome_changes", "run_changes", "episode_source", "sign_test"]

PAIRED_OUTCOMES = ("reached_goal", "collided")


def outcome_changes(base: list[dict], new: list[dict]) -> dict[str, tuple[int, int]]:
    """For each of :data:`PAIRED_OUTCOMES`, ``(gained, lost)``: the episodes whose outcome is it
    in ``new`` and not in ``base``, and the other way round. ``base`` and ``new``: the two runs'
    ``episodes_detail`` rows (``scenario``, ``outcome``), the same episodes in the same order
    (ValueError otherwise: a suite may hold a scenario name twice, so rows pair by place)."""
    if len(base) != len(new):
        raise ValueError(f"not the same episodes: {len(base)} against {len(new)}")
    for i, (a, b) in enumerate(zip(base, new)):
        if a["scenario"] != b["scenario"]:
            raise ValueError(f"not the same episodes: episode {i} is {a['scenario']!r} in one run, "
                             f"{b['scenario']!r} in the other")
    return {o: (sum(b["outcome"] == o != a["outcome"] for a, b in zip(base, new)),
                sum(a["outcome"] == o != b["outcome"] for a, b in zip(base, new))) for o in PAIRED_OUTCOMES}


def episode_source(doc: dict) -> dict | None:
    """What an EVAL document records of where its episodes came from, beyond their names: its
    suite's settings (``suite_spec``: suite, count, seed, movers, behaviour; ``suite`` and
    ``seed`` in a document without it), or None for scenario files (their names are all it
    records of them)."""
    if doc.get("suite_spec") is not None:
        return dict(doc["suite_spec"])
    return None if doc.get("suite") is None else {"suite": doc["suite"], "seed": doc.get("seed")}


def run_changes(base: dict, new: dict) -> dict[str, tuple[int, int]]:
    """:func:`outcome_changes` of two EVAL documents, refused (ValueError, one line) unless they
    ran the same cases: the same suite with the same settings, or both scenario files. A
    name alone does not say it: the crowd suite ``ucy`` names an episode by its recorded case,
    whatever the seed that orders the cases and draws the sensor's noise."""
    a, b = episode_source(base), episode_source(new)
    if a != b:
        if a is None or b is None:
            suite = (a or b)["suite"]
            raise ValueError(f"not the same episodes: scenario files in one run, suite {suite!r} in the other")
        # a setting only one records (an EVAL before suite_spec: suite and seed) is no difference
        differ = [f"{k} {a[k]!r} against {b[k]!r}" for k in a if k in b and a[k] != b[k]]
        if differ:
            raise ValueError(f"not the same episodes: the suites differ in {', '.join(differ)}")
    return outcome_changes(base["episodes_detail"], new["episodes_detail"])


def sign_test(gained: int, lost: int) -> float:
    """The two-sided exact sign test of ``gained`` against ``lost`` (1.0 when nothing changed)."""
    n = gained + lost
    return 1.0 if n == 0 else float(binomtest(gained, n, 0.5).pvalue)
