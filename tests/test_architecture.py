"""The house rules of docs/architecture.md, read from the source (ast), so that they stay
true: imports go one way between the floors, no import circle, no module over 500 lines,
and the numpy-only modules import with CasADi and torch made unimportable."""
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
    assert not wrong


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
             "nn_export.runtime.tracker", "nn_export.runtime.policy", "casadi_gpc.tracking", "casadi_gpc.selection",
             "casadi_gpc.safety", "casadi_gpc.pool", "casadi_gpc.io", "casadi_gpc.ekf", "casadi_gpc.robot"]
    script = BLOCKER + "import importlib\n" + "".join(f"importlib.import_module({n!r})\n" for n in names) + \
        "print('OK')\n"
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120, cwd=REPO)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip() == "OK"
