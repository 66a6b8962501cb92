"""The package's dependency rules (docs/architecture.md), checked on the source itself.

Every ``import`` and ``from ... import`` in ``src/stackik`` counts, at module level or
inside functions (only ``if TYPE_CHECKING:`` blocks are left out: they never run). An
import of ``stackik.a.b`` is an edge to the module ``stackik.a.b``; ``from stackik.a import
b`` is an edge to ``stackik.a.b`` when that is a module, else to ``stackik.a``.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src"
PKG = SRC / "stackik"

#: Layers from the top; a module may import its own layer and the layers below it.
LAYERS: tuple[tuple[str, ...], ...] = (
    ("stackik.cli", "stackik.__main__", "stackik.ik", "stackik"),  # entry points, compat
    ("stackik.bench",),
    ("stackik.analysis", "stackik.paths", "stackik.distributed", "stackik.viz"),
    ("stackik.solve",),
    ("stackik.methods",),
    ("stackik.convex", "stackik.starts"),
    ("stackik.formulation", "stackik._compiled.check"),
    ("stackik.check", "stackik.clearance", "stackik.result", "stackik.targets", "stackik.sampling"),
    ("stackik.loads",),  # statics: leg forces and singularity margins
    ("stackik.kinematics",),
    ("stackik.geometry", "stackik.platform", "stackik.obstacles"),
    ("stackik.rotations",),
    # engines and utilities: import nothing of the layers above (rules below)
    (
        "stackik.sqp",
        "stackik.distance",
        "stackik._compiled",
        "stackik.batch",
        "stackik._threads",
        "stackik._io",
        "stackik._version",
        "stackik._arrays",
        "stackik.families",
    ),
)

#: What the engines may import from stackik (nothing of the orchestration).
ENGINE_RULES: dict[str, tuple[str, ...]] = {
    "stackik.sqp": ("stackik.sqp",),
    # the user's constraint families, called back in object mode (stackik.families
    # itself imports nothing of stackik)
    "stackik._compiled": ("stackik.families",),
    "stackik.families": (),
    # the compiled twin of the acceptance rule: shares no code with the solvers it checks
    "stackik._compiled.check": ("stackik.check", "stackik._arrays"),
    # a batch worker runs each solve on one thread (stackik._threads imports nothing)
    "stackik.batch": ("stackik._threads",),
    "stackik._threads": (),
    "stackik.distance": (),
}


def _modules() -> dict[str, Path]:
    out = {}
    for path in PKG.rglob("*.py"):
        parts = list(path.relative_to(SRC).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts = parts[:-1]
        out[".".join(parts)] = path
    return out


MODULES = _modules()


def _type_checking_lines(tree: ast.AST) -> set[int]:
    lines: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            for sub in node.body:
                for inner in ast.walk(sub):
                    if hasattr(inner, "lineno"):
                        lines.add(inner.lineno)
    return lines


def _imports(name: str, path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    skip = _type_checking_lines(tree)
    is_pkg = path.name == "__init__.py"
    out: set[str] = set()
    for node in ast.walk(tree):
        if getattr(node, "lineno", None) in skip:
            continue
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.split(".")[0] == "stackik"}
        elif isinstance(node, ast.ImportFrom):
            if node.level:  # relative import
                base = name.split(".") if is_pkg else name.split(".")[:-1]
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.split(".")[0] != "stackik":
                continue
            for alias in node.names:
                sub = f"{mod}.{alias.name}"
                out.add(sub if sub in MODULES else mod)
    out.discard(name)
    return out


GRAPH = {name: _imports(name, path) for name, path in MODULES.items()}


def _layer(module: str) -> int:
    best, depth = -1, -1
    for i, layer in enumerate(LAYERS):
        for prefix in layer:
            if module == prefix or module.startswith(prefix + "."):
                if len(prefix) > depth:
                    best, depth = i, len(prefix)
    return best


def _cycles() -> list[list[str]]:
    """Strongly connected components with more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    counter = [0]

    def visit(v: str) -> None:
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in GRAPH.get(v, ()):
            if w not in GRAPH:
                continue
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
                out.append(sorted(comp))

    for v in sorted(GRAPH):
        if v not in index:
            visit(v)
    return out


def test_the_graph_sees_function_level_imports():
    # the solve pipeline imports the convex start inside a function: it must be an edge
    assert "stackik.convex" in GRAPH["stackik.solve.request"]
    assert "stackik._compiled.check" in GRAPH["stackik.methods.ip"]


def test_no_import_cycle():
    assert _cycles() == []


def test_every_module_has_a_layer():
    assert [m for m in MODULES if _layer(m) < 0] == []


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_respect_the_layers(module):
    mine = _layer(module)
    upward = sorted(t for t in GRAPH[module] if t in MODULES and _layer(t) < mine)
    assert upward == [], f"{module} (layer {mine}) imports from layers above it: {upward}"


def _engine_of(module: str) -> str | None:
    """The most specific engine of ``module`` (``stackik._compiled.check`` has a rule of
    its own inside ``stackik._compiled``), or None."""
    inside = [e for e in ENGINE_RULES if module == e or module.startswith(e + ".")]
    return max(inside, key=len) if inside else None


@pytest.mark.parametrize("engine", sorted(ENGINE_RULES))
def test_engines_import_nothing_of_the_orchestration(engine):
    allowed = ENGINE_RULES[engine]
    for module, targets in GRAPH.items():
        if _engine_of(module) != engine:
            continue
        bad = sorted(
            t
            for t in targets
            if not any(t == a or t.startswith(a + ".") for a in allowed)
            and not (t == engine or t.startswith(engine + "."))
        )
        assert bad == [], f"{module} imports {bad}"


def test_nothing_inside_the_package_imports_the_compat_module():
    users = sorted(m for m, targets in GRAPH.items() if "stackik.ik" in targets and m != "stackik")
    assert users == []


def test_a_method_is_one_module_plus_one_registry_line():
    from stackik.cli import _common  # noqa: F401 - the CLI derives its choices from here
    from stackik.methods import METHOD_NAMES, get_method

    for name in METHOD_NAMES[1:]:
        assert get_method(name).name == name
    with pytest.raises(ValueError, match="choose one of"):
        get_method("no-such-method")
