"""The suite's own rules, read from its source and its collected tests: tests use the
package's public names only, share helpers through conftest.py and not through each other,
assert properties, not speeds (benchmarks/ measures those) or the outcome of a race against
a sleep, and a test that needs a dataset solved for the suite is out of the fast loop."""

import ast
from collections.abc import Iterator
from pathlib import Path

import pytest

from conftest import SHARED_DATASETS

TESTS = Path(__file__).parent
CLOCKS = {"perf_counter", "perf_counter_ns", "time", "time_ns", "monotonic", "monotonic_ns", "process_time"}


def private(name: str) -> bool:
    return name.startswith("_") and not (name.startswith("__") and name.endswith("__"))


def clock_call(node: ast.AST) -> bool:
    """``time.perf_counter()`` and the like, or the bare name imported from ``time``."""
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    if isinstance(f, ast.Attribute):
        return f.attr in CLOCKS and isinstance(f.value, ast.Name) and f.value.id == "time"
    return isinstance(f, ast.Name) and f.id in {"perf_counter", "perf_counter_ns", "monotonic", "monotonic_ns"}


def sleep_call(node: ast.AST) -> bool:
    if not isinstance(node, ast.Call):
        return False
    f = node.func
    return (isinstance(f, ast.Attribute) and f.attr == "sleep") or (isinstance(f, ast.Name) and f.id == "sleep")


def timed(tree: ast.AST) -> set[str]:
    """Names that hold a clock reading or a value computed from one (``start = perf_counter()``,
    ``seconds.append(perf_counter() - start)``), to a fixed point."""
    names: set[str] = set()

    def tainted(expr: ast.AST) -> bool:
        return any(clock_call(n) or (isinstance(n, ast.Name) and n.id in names) for n in ast.walk(expr))

    while True:
        before = len(names)
        for node in ast.walk(tree):
            if isinstance(node, ast.Assign | ast.AugAssign | ast.AnnAssign) and node.value is not None:
                if tainted(node.value):
                    targets = node.targets if isinstance(node, ast.Assign) else [node.target]
                    names |= {n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)}
            elif (isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute)
                  and node.func.attr in ("append", "extend") and isinstance(node.func.value, ast.Name)
                  and any(tainted(a) for a in node.args)):
                names.add(node.func.value.id)
        if len(names) == before:
            return names


def offences(path: Path) -> Iterator[str]:
    """Each breach of the rules in one test file, as ``file:line: what``."""
    tree = ast.parse(path.read_text(), filename=str(path))

    def where(node: ast.AST) -> str:
        return f"{path.name}:{node.lineno}"

    from_package: set[str] = set()  # names bound by imports from cocomopl
    for node in ast.walk(tree):
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            top = node.module.split(".")[0]
            if top == "cocomopl":
                if any(private(part) for part in node.module.split(".")):
                    yield f"{where(node)}: imports the private module {node.module}"
                for alias in node.names:
                    if private(alias.name):
                        yield f"{where(node)}: imports the private name {alias.name} from {node.module}"
                    from_package.add(alias.asname or alias.name)
            if top == "tests" or top.startswith("test_"):
                yield f"{where(node)}: imports the test module {node.module} (shared helpers go in conftest.py)"
        elif isinstance(node, ast.Import):
            for alias in node.names:
                parts = alias.name.split(".")
                if parts[0] == "cocomopl":
                    if any(private(part) for part in parts):
                        yield f"{where(node)}: imports the private module {alias.name}"
                    from_package.add(alias.asname or parts[0])
                if parts[0] == "tests" or parts[0].startswith("test_"):
                    yield f"{where(node)}: imports the test module {alias.name} (shared helpers go in conftest.py)"
    clocked = timed(tree)
    for node in ast.walk(tree):
        if (isinstance(node, ast.Attribute) and private(node.attr) and isinstance(node.value, ast.Name)
                and node.value.id in from_package):
            yield f"{where(node)}: uses the private name {node.value.id}.{node.attr}"
        if isinstance(node, ast.Assert) and any(
            clock_call(n) or (isinstance(n, ast.Name) and n.id in clocked) for n in ast.walk(node.test)
        ):
            yield f"{where(node)}: asserts on a time measured by a clock (a speed belongs in benchmarks/)"
    polling = {id(n) for loop in ast.walk(tree) if isinstance(loop, ast.While) for n in ast.walk(loop)}
    for node in ast.walk(tree):
        if sleep_call(node) and id(node) not in polling:
            yield f"{where(node)}: sleeps outside a loop polling for a condition (a race against time)"


def test_the_suite_keeps_its_rules():
    found = [line for path in sorted(TESTS.glob("*.py")) for line in offences(path)]
    assert not found, "\n".join(found)


@pytest.mark.parametrize(
    ("source", "offence"),
    [
        ("from cocomopl.ocp import _hidden", "private name _hidden"),
        ("import cocomopl.ocp._inner", "private module cocomopl.ocp._inner"),
        ("from cocomopl.primitives import model_file\nmodel_file._ARRAYS", "private name model_file._ARRAYS"),
        ("from test_sim import standing", "test module test_sim"),
        ("import tests.test_sim", "test module tests.test_sim"),
        ("import time\ns = []\nt = time.perf_counter()\ns.append(time.perf_counter() - t)\nassert min(s) < 0.25",
         "clock"),
        ("import time\nstart = time.time()\nassert time.time() - start < 1", "clock"),
        ("import time\ntime.sleep(2)\nkill()", "sleeps outside"),
    ],
)
def test_each_rule_finds_its_breach(tmp_path, source, offence):
    path = tmp_path / "test_example.py"
    path.write_text(source + "\n")
    (found,) = offences(path)
    assert offence in found


def test_polling_with_a_deadline_and_public_names_pass(tmp_path):
    path = tmp_path / "test_example.py"
    path.write_text(
        "import time\nfrom cocomopl.ocp.first_knot import barrier_qp\nfrom conftest import run_cli\n"
        "deadline = time.monotonic() + 120\n"
        "while not done() and time.monotonic() < deadline:\n    time.sleep(0.02)\n"
        "assert done()\nassert barrier_qp.__doc__\n"
    )
    assert list(offences(path)) == []


def test_a_test_that_needs_a_shared_dataset_is_marked_slow(request):
    """The shared datasets (conftest.py) take 40-90 s to solve: a test that needs one (or a
    fixture built on one) is out of the fast loop, ``-m 'not slow'`` (conftest.py marks it)."""
    assert {"small_dataset", "turning_dataset"} <= SHARED_DATASETS
    solving = SHARED_DATASETS
    unmarked = [item.nodeid for item in request.session.items
                if solving & set(getattr(item, "fixturenames", ())) and item.get_closest_marker("slow") is None]
    assert unmarked == []
