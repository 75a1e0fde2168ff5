"""The package layout as the architecture doc draws it (docs/architecture.md): which
part of attitude_core may import which, no ROS below the node shells, thin shells, short
test files. Read from the sources with ``ast``, nothing imported."""

from __future__ import annotations

import ast
import importlib.util
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
CORE = ROOT / "src" / "attitude_core" / "attitude_core"
TOOLS = ROOT / "src" / "attitude_tools" / "attitude_tools"

# What each part of attitude_core may import at run time (imports under TYPE_CHECKING
# are type information only). "yamlio" and "closed_loop" are top-level modules.
ALLOWED = {
    "yamlio": set(),
    "gnc": {"gnc", "contract.status", "yamlio"},
    "config": {"config", "gnc", "contract.status", "contract.time_mode", "yamlio"},
    "contract": {"contract", "config"},
    "runtime": {"runtime", "gnc", "config", "contract"},
    "record": {"record", "gnc", "config", "contract"},
    "closed_loop": {"gnc", "config", "contract", "record"},
}
SHELLS = [
    "attitude_planner/attitude_planner/planner_node.py",
    "attitude_controller/attitude_controller/controller_node.py",
    "spacecraft_sim/spacecraft_sim/sim_node.py",
    "attitude_estimation/attitude_estimation/estimator_node.py",
    "attitude_bringup/attitude_bringup/recorder_node.py",
    "attitude_conformance/attitude_conformance/check_node.py",
]


def _part(module: str) -> str:
    """``attitude_core.gnc.fepf`` -> ``gnc``; ``attitude_core.contract.status`` ->
    ``contract.status`` when that module has a rule of its own."""
    parts = module.split(".")[1:]
    if len(parts) >= 2 and ".".join(parts[:2]) in _FINE:
        return ".".join(parts[:2])
    return parts[0] if parts else ""


_FINE = {rule for rules in ALLOWED.values() for rule in rules if "." in rule}


def _runtime_imports(path: Path) -> set[str]:
    """Absolute attitude_* modules imported by ``path``, outside ``if TYPE_CHECKING``."""
    tree = ast.parse(path.read_text(encoding="utf-8"))
    skip: set[int] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.If) and "TYPE_CHECKING" in ast.unparse(node.test):
            skip.update(id(n) for b in node.body for n in ast.walk(b))
    found = set()
    for node in ast.walk(tree):
        if id(node) in skip:
            continue
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [f"{node.module}.{a.name}" for a in node.names]
            found.update(
                n for n in names if importlib.util.find_spec(node.module) and _is_module(n)
            )
            found.add(node.module)
        elif isinstance(node, ast.Import):
            found.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.level:
            package = _module_name(path).split(".")[: -node.level]
            found.add(".".join(package + ([node.module] if node.module else [])))
    return found


def _module_name(path: Path) -> str:
    """``src/<dist>/<package>/a/b.py`` -> ``package.a.b``."""
    rel = path.relative_to(ROOT / "src").with_suffix("").parts[1:]
    return ".".join(rel)


def _is_module(dotted: str) -> bool:
    try:
        return importlib.util.find_spec(dotted) is not None
    except (ImportError, ValueError):
        return False


def _core_files() -> list[Path]:
    return sorted(p for p in CORE.rglob("*.py") if "__pycache__" not in p.parts)


def _owner(path: Path) -> str:
    rel = path.relative_to(CORE).with_suffix("")
    return rel.parts[0]


@pytest.mark.parametrize("path", _core_files(), ids=lambda p: str(p.relative_to(CORE)))
def test_core_imports_follow_the_layers(path):
    owner = _owner(path)
    if owner == "__init__":
        return
    allowed = ALLOWED[owner] | {owner}
    for module in _runtime_imports(path):
        top = module.split(".")[0]
        assert top not in ("rclpy", "attitude_ros", "attitude_tools"), f"{path}: imports {module}"
        if top != "attitude_core" or module == "attitude_core":
            continue
        part = _part(module)
        assert part in allowed or part.split(".")[0] in allowed, (
            f"{path.relative_to(CORE)} imports {module}: {owner}/ may import {sorted(allowed)}"
        )


def test_core_top_level_is_small_and_every_part_is_documented():
    modules = sorted(p.name for p in CORE.glob("*.py"))
    assert len(modules) <= 6, modules
    for package in [p for p in CORE.iterdir() if (p / "__init__.py").exists()]:
        doc = ast.get_docstring(ast.parse((package / "__init__.py").read_text(encoding="utf-8")))
        assert doc and len(doc) > 80, (
            f"{package.name}/__init__.py needs its job, inputs and outputs"
        )
    architecture = (ROOT / "docs" / "architecture.md").read_text(encoding="utf-8")
    for package in [p.name for p in CORE.iterdir() if (p / "__init__.py").exists()]:
        assert f"`{package}/`" in architecture, f"docs/architecture.md does not name {package}/"


ROS2_VERBS = TOOLS / "ros2cli"
"""The ``ros2`` shim's graph verbs (``topic``, ``node``, ``lifecycle``, ``param``): the one
part of attitude_tools that talks to a live graph, so it imports rclpy (from .venv,
with no workspace sourced); only a verb that needs it loads it."""


def test_attitude_tools_never_imports_rclpy():
    for path in sorted(TOOLS.rglob("*.py")):
        if ROS2_VERBS in path.parents:
            continue
        for module in _runtime_imports(path):
            assert module.split(".")[0] not in ("rclpy", "attitude_ros"), f"{path}: {module}"
    for path in sorted(ROS2_VERBS.rglob("*.py")):  # the verbs: rclpy, never our nodes' code
        for module in _runtime_imports(path):
            assert module.split(".")[0] != "attitude_ros", f"{path}: {module}"


def _code_lines(source: str) -> int:
    spec = importlib.util.spec_from_file_location("code_lines", ROOT / "tools" / "code_lines.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    count: int = module.code_lines(source)
    return count


@pytest.mark.parametrize("shell", SHELLS)
def test_node_shells_are_thin(shell):
    lines = _code_lines((ROOT / "src" / shell).read_text(encoding="utf-8"))
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
