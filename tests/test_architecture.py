"""The house rules of docs/architecture.md, read from the source (ast), so that they stay
true: imports go one way between the floors and between the rooms of ``casadi_gpc``, the
robot's side imports nothing of the world it is tested in, no import circle, no module over
500 lines, and the numpy-only modules import with CasADi and torch made unimportable."""
from __future__ import annotations

import ast
import subprocess
import sys
from pathlib import Path

from test_deploy_isolation import BLOCKER

REPO = Path(__file__).resolve().parents[1]
PACKAGES = ("casadi_gpc", "nn_export", "scenarios", "gpcnav")


def _modules() -> dict[str, Path]:
    mods = {}
    for pkg in PACKAGES:
        for path in (REPO / pkg).rglob("*.py"):
            name = ".".join(path.relative_to(REPO).with_suffix("").parts)
            mods[name.removesuffix(".__init__")] = path
    return mods


def _imports(name: str, path: Path) -> set[str]:
    """Every module (of any package) that ``name`` imports, at any depth of its code."""
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out = set()
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                parts = package.split(".")
                base = ".".join(parts[: len(parts) - node.level + 1] + ([node.module] if node.module else []))
            out.add(base)
            out.update(f"{base}.{a.name}" for a in node.names)
    return out


def _graph() -> dict[str, set[str]]:
    mods = _modules()
    graph = {}
    for name, path in mods.items():
        graph[name] = {m for m in _imports(name, path) if m in mods and m != name and not name.startswith(m + ".")}
    return graph


def _all_imports() -> dict[str, set[str]]:
    return {name: _imports(name, path) for name, path in _modules().items()}


def test_imports_go_one_way_between_the_floors():
    wrong = []
    for name, targets in _all_imports().items():
        for t in targets:
            top = t.split(".")[0]
            if name.startswith("nn_export.runtime") and (t.startswith("nn_export.training")
                                                          or top in ("torch", "casadi", "onnx")):
                wrong.append((name, t))
            if name.startswith("casadi_gpc") and top in ("torch", "nn_export", "gpcnav"):
                wrong.append((name, t))
            if not name.startswith("gpcnav") and top == "gpcnav":
                wrong.append((name, t))
            if name.startswith("scenarios") and top == "nn_export":
                wrong.append((name, t))
            if name.startswith("casadi_gpc") and top == "scenarios":  # the robot never imports the world
                wrong.append((name, t))
    assert not wrong


ROOMS = ("", "estimation", "problem", "solvers", "planner", "safety")
"""The rooms of ``casadi_gpc`` from the bottom up ("" : the modules at its top, the model, the
reference, the typed data, the presets, file writing, the worker pool): a room imports only
rooms below it (docs/architecture.md). The package's own ``__init__`` is its front desk and
reaches any room."""


def _room(name: str) -> str:
    parts = name.split(".")
    return parts[1] if len(parts) >= 2 and parts[1] in ROOMS else ""


def test_rooms_of_the_robot_import_downwards_only():
    wrong = []
    for name, targets in _graph().items():
        if not name.startswith("casadi_gpc.") or name == "casadi_gpc":
            continue
        here = ROOMS.index(_room(name))
        for t in targets:
            if t.startswith("casadi_gpc.") and ROOMS.index(_room(t)) > here:
                wrong.append((name, t))
    assert not wrong


def test_the_world_lives_outside_the_robot():
    """The simulator, the movers, the episode measures and the plots are ``scenarios``'s; no
    module of that kind is left under ``casadi_gpc``, and no room of it is missing."""
    mods = _modules()
    world = ("simulator", "movers", "metrics", "plots", "bench", "bench_decisions")
    assert not [m for m in mods if m.startswith("casadi_gpc.") and m.rsplit(".", 1)[1] in world]
    for m in ("scenarios.simulator", "scenarios.movers", "scenarios.metrics", "scenarios.plots",
              "casadi_gpc.estimation.ekf", "casadi_gpc.problem.cost", "casadi_gpc.planner.gpc",
              "casadi_gpc.solvers", "casadi_gpc.safety.shield"):
        assert m in mods, m
    tops = {n.split(".")[1] for n in mods if n.startswith("casadi_gpc.")}
    assert tops <= set(ROOMS) | {"finite", "robot", "reference", "progress", "types", "config", "io", "pool",
                                 "buffered", "geometry"}


def test_no_import_circle():
    graph = _graph()
    index, low, stack, on, circles = {}, {}, [], set(), []

    def visit(v):  # Tarjan's strongly connected components
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in graph[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                circles.append(sorted(comp))

    for v in graph:
        if v not in index:
            visit(v)
    assert not circles


def test_no_module_over_500_lines():
    long = {name: n for name, path in _modules().items() if (n := len(path.read_text().splitlines())) > 500}
    assert not long


def test_numpy_only_modules_import_without_casadi_or_torch():
    """The deployed floor and the numpy-only rooms of casadi_gpc import with torch, CasADi,
    onnx, scipy and matplotlib blocked."""
    names = ["nn_export.runtime.layouts", "nn_export.runtime.situation", "nn_export.runtime.features",
             "nn_export.runtime.tracker", "nn_export.runtime.policy", "casadi_gpc.estimation",
             "casadi_gpc.estimation.tracking", "casadi_gpc.estimation.track_rows", "casadi_gpc.estimation.ekf_batch",
             "casadi_gpc.problem.selection",
             "casadi_gpc.planner", "casadi_gpc.safety", "casadi_gpc.pool", "casadi_gpc.io", "casadi_gpc.robot",
             "casadi_gpc.geometry"]
    script = BLOCKER + "import importlib\n" + "".join(f"importlib.import_module({n!r})\n" for n in names) + \
        "print('OK')\n"
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "OK"
