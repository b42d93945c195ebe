"""The package's layering rule (docs/architecture.md, "Layering"), read from the import statements.

The core (the Motion type, files, robot, walking vocabulary and footstep plans,
kinematics, dynamics, analysis, bundled data) is used by every stage and imports none.  The stages come in
pipeline order, and each imports the core and earlier stages only.  Nothing but
``__main__`` imports the command line.
"""

import ast
from pathlib import Path

import pytest

import cocomopl

PACKAGE = Path(cocomopl.__file__).parent
ROOT = PACKAGE.parent
CORE = {"cocomopl", "errors", "motion", "motion_file", "validation", "provenance", "processes", "robot", "gait", "kinematics", "dynamics",
        "analysis", "data", "planning"}
STAGES = ["ocp", "dataset", "primitives", "synthesis", "sim", "baselines", "export", "requests", "online", "results", "pipeline",
          "jobs", "bootstrap", "options", "cli", "__main__"]


def layer(path: Path) -> str:
    """The core module or stage a file of the package belongs to."""
    relative = path.relative_to(PACKAGE)
    return relative.parts[0] if len(relative.parts) > 1 else relative.stem.replace("__init__", "cocomopl")


def imported_layers(path: Path) -> set[str]:
    """The layers of cocomopl a file imports from (lazy imports inside functions included)."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        names = []
        if isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        elif isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        for name in names:
            parts = name.split(".")
            if parts[0] == "cocomopl":
                out.add(parts[1] if len(parts) > 1 else "cocomopl")
    return out


SOURCES = sorted(PACKAGE.rglob("*.py"))


def test_every_module_belongs_to_a_layer():
    unknown = {layer(p) for p in SOURCES} - CORE - set(STAGES)
    assert not unknown, f"modules outside the layering rule: {unknown}"


@pytest.mark.parametrize("path", SOURCES, ids=lambda p: str(p.relative_to(PACKAGE)))
def test_imports_follow_the_layers(path):
    own = layer(path)
    allowed = CORE | set(STAGES[: STAGES.index(own)]) if own in STAGES else CORE
    assert imported_layers(path) - {own} <= allowed, f"{own} imports {imported_layers(path) - {own} - allowed}"


def test_ocp_imports_no_later_stage():
    later = set(STAGES[1:])
    for path in (PACKAGE / "ocp").glob("*.py"):
        assert not imported_layers(path) & later, path


def test_only_main_and_cli_tests_use_the_command_line_module():
    users = [p for p in [*SOURCES, *ROOT.glob("benchmarks/*.py"), *ROOT.glob("scripts/*.py")]
             if "cocomopl.cli" in p.read_text() and p.name not in ("__main__.py", "cli.py")]
    assert users == []
    assert "cocomopl.cli" not in (ROOT / "README.md").read_text()
