"""The package layout as the architecture doc draws it (docs/architecture.md): the
import-linter contracts of pyproject.toml (``lint-imports`` in tools/test enforces them)
written out in the doc word for word, every core subpackage in a layer and in the doc,
no import circle anywhere in ``src/`` (an AST graph of every import, independent of
import-linter), thin node shells, short test files. Read from the sources with ``ast``,
nothing imported."""

from __future__ import annotations

import ast
import importlib.util
import tomllib
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SRC = ROOT / "src"
CORE = SRC / "attitude_core" / "attitude_core"
ARCHITECTURE = ROOT / "docs" / "architecture.md"
SHELLS = [
    "attitude_planner/attitude_planner/planner_node.py",
    "attitude_controller/attitude_controller/controller_node.py",
    "spacecraft_sim/spacecraft_sim/sim_node.py",
    "attitude_estimation/attitude_estimation/estimator_node.py",
    "attitude_bringup/attitude_bringup/recorder_node.py",
    "attitude_bringup/attitude_bringup/lifecycle_manager_node.py",
    "attitude_conformance/attitude_conformance/check_node.py",
]
BEGIN, END = "<!-- contracts: begin -->", "<!-- contracts: end -->"


def _contracts() -> list[dict[str, object]]:
    config = tomllib.loads((ROOT / "pyproject.toml").read_text(encoding="utf-8"))
    contracts: list[dict[str, object]] = config["tool"]["importlinter"]["contracts"]
    return contracts


def render_contracts() -> str:
    """The contracts as the doc lists them: one block per contract, layers top down."""
    out = []
    for c in _contracts():
        out.append(f"{c['id']} ({c['type']}): {c['name']}")
        if c["type"] == "layers":
            prefix = f"{c['containers'][0]}." if c.get("containers") else ""  # type: ignore[index]
            for layer in c["layers"]:  # type: ignore[attr-defined]
                sep = " : " if ":" in layer else " | "
                names = [n.strip() for n in layer.replace(":", "|").split("|")]
                out.append("    " + sep.join(prefix + n for n in names))
        else:
            out.append(f"    {', '.join(c['source_modules'])}")  # type: ignore[arg-type]
            out.append(f"    must not import {', '.join(c['forbidden_modules'])}")  # type: ignore[arg-type]
    return "\n".join(out)


def test_architecture_doc_states_the_contracts_word_for_word():
    text = ARCHITECTURE.read_text(encoding="utf-8")
    assert BEGIN in text and END in text, f"docs/architecture.md needs {BEGIN} ... {END}"
    block = text.split(BEGIN, 1)[1].split(END, 1)[0].strip().strip("`").strip()
    assert block == render_contracts(), (
        "docs/architecture.md's contract block differs from pyproject.toml; it should read:\n"
        + render_contracts()
    )


def _core_packages() -> list[str]:
    return sorted(p.name for p in CORE.iterdir() if (p / "__init__.py").exists())


def test_every_core_subpackage_is_in_a_layer_and_documented():
    core = next(c for c in _contracts() if c["id"] == "core-layers")
    layered = {
        name.strip()
        for layer in core["layers"]  # type: ignore[attr-defined]
        for name in layer.replace(":", "|").split("|")
    }
    top_modules = {p.stem for p in CORE.glob("*.py")} - {"__init__"}
    assert set(_core_packages()) | top_modules == layered, (
        "every part of attitude_core must sit in the core-layers contract"
    )
    text = ARCHITECTURE.read_text(encoding="utf-8")
    for package in _core_packages():
        assert f"`{package}/`" in text, f"docs/architecture.md does not name {package}/"
        doc = ast.get_docstring(ast.parse((CORE / package / "__init__.py").read_text()))
        assert doc and len(doc) > 80, f"{package}/__init__.py needs its job, inputs and outputs"
    assert len(top_modules) <= 3, sorted(top_modules)


def _module_of(path: Path) -> str:
    """``src/<dist>/<package>/a/b.py`` -> ``package.a.b`` (a package: its ``__init__``)."""
    parts = list(path.relative_to(SRC).with_suffix("").parts[1:])
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> dict[str, set[str]]:
    """Every module of ``src/`` -> the modules of ``src/`` it imports: every import
    statement, at any depth (functions, ``if TYPE_CHECKING``), relative ones resolved;
    ``from package import name`` counts the submodule when ``name`` is one."""
    files = [
        p
        for p in SRC.rglob("*.py")
        if "__pycache__" not in p.parts and len(p.relative_to(SRC).parts) > 2
    ]
    modules = {_module_of(p): p for p in files}
    graph: dict[str, set[str]] = {}
    for name, path in modules.items():
        is_package = path.name == "__init__.py"
        deps: set[str] = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Import):
                deps.update(a.name for a in node.names if a.name in modules)
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    here = name.split(".") if is_package else name.split(".")[:-1]
                    here = here[: len(here) - (node.level - 1)]
                    base = ".".join(here + ([node.module] if node.module else []))
                for a in node.names:
                    if f"{base}.{a.name}" in modules:
                        deps.add(f"{base}.{a.name}")
                    elif base in modules:
                        deps.add(base)
        deps.discard(name)
        graph[name] = deps
    return graph


def cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one module (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on_stack.add(v)
        for w in sorted(graph.get(v, ())):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on_stack:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            component = []
            while True:
                w = stack.pop()
                on_stack.discard(w)
                component.append(w)
                if w == v:
                    break
            if len(component) > 1:
                found.append(sorted(component))

    for v in sorted(graph):
        if v not in index:
            visit(v)
    return found


def test_no_import_circle_anywhere_in_src():
    graph = import_graph()
    assert len(graph) > 150, "the graph misses modules"
    assert cycles(graph) == []


def test_the_cycle_finder_finds_a_circle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def _code_lines(source: str) -> int:
    spec = importlib.util.spec_from_file_location("code_lines", ROOT / "tools" / "code_lines.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    count: int = module.code_lines(source)
    return count


@pytest.mark.parametrize("shell", SHELLS)
def test_node_shells_are_thin(shell):
    lines = _code_lines((SRC / shell).read_text(encoding="utf-8"))
    assert lines <= 150, f"{shell}: {lines} code lines (at most 150: the logic goes to the core)"


def test_code_lines_counts_code_not_blank_or_comment_lines():
    assert _code_lines('"""doc\nmore"""\n\n# note\nx = 1  # one\n\n') == 3


def test_no_test_file_over_600_lines():
    long = {
        str(p.relative_to(ROOT)): n
        for p in (ROOT / "tests").rglob("*.py")
        if (n := len(p.read_text(encoding="utf-8").splitlines())) > 600
    }
    assert not long, long
