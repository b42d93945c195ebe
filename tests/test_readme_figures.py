"""The README's figures come from docs/results.md, and the docs agree with the program.

* The README's results table is short (at most 10 rows of cells of at most 120 characters),
  and each row links to its section of docs/results.md, which holds the row's figures and its
  command.
* Every link in the README and docs/*.md stays in the repository and finds its file and
  heading.
* A sentence of the docs that cites a section of docs/results.md states only figures found there.
* Figures that prose repeats are checked against their source: MP's torque against Kajita's
  (Table I in docs/results.md), the bundled model's explained variance and training time (its
  file's metadata).
* The README's Python example prints what it computes and says which extra ``fit`` needs.
* The changelog's latest release is the version of the package, pyproject.toml and CITATION.cff.
"""

import ast
import json
import re
from pathlib import Path

import numpy as np
import pytest

from cocomopl.data import BUNDLED_MODEL

ROOT = Path(__file__).parents[1]
README = ROOT / "README.md"
RESULTS = ROOT / "docs" / "results.md"
LINK = re.compile(r"\]\(([^)\s]+)\)")
NUMBER = re.compile(r"\d+(?:[ .,]\d+)*")


def slug(heading: str) -> str:
    """GitHub's anchor for a Markdown heading."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def headings(path: Path) -> dict[str, int]:
    """Anchor -> line index of every heading of ``path`` (code blocks left out)."""
    found, fenced = {}, False
    for index, line in enumerate(path.read_text(encoding="utf-8").splitlines()):
        fenced ^= line.startswith("```")
        if not fenced and (match := re.match(r"(#+) (.*)", line)):
            found[slug(match.group(2))] = index
    return found


def section(path: Path, anchor: str) -> str:
    """The text under the heading ``anchor`` of ``path``, up to the next heading of its level or above."""
    lines = path.read_text(encoding="utf-8").splitlines()
    start = headings(path)[anchor]
    level = len(lines[start]) - len(lines[start].lstrip("#"))
    end = next((i for i in range(start + 1, len(lines))
                if re.match(rf"#{{1,{level}}} ", lines[i])), len(lines))
    return "\n".join(lines[start:end])


def results_table() -> list[list[str]]:
    """The cells of the README's results table, header and rule left out."""
    text = README.read_text(encoding="utf-8").split("## Results", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in text.splitlines() if line.startswith("|")]
    return [[cell.strip() for cell in row.strip("|").split(" | ")] for row in rows[2:]]


def plain(cell: str) -> str:
    return LINK.sub("", cell).replace("**", "").replace("`", "")


def test_the_readme_results_table_is_short():
    rows = results_table()
    assert 1 <= len(rows) <= 11  # ten for TALOS, one for the G1
    for row in rows:
        assert len(row) == 3, row
        assert all(len(cell) <= 120 for cell in row), row


@pytest.mark.parametrize("row", results_table(), ids=lambda row: plain(row[0])[:40])
def test_each_readme_figure_is_in_its_section_of_results(row):
    figure, value, command = row
    target = LINK.search(figure)
    assert target and target.group(1).startswith("docs/results.md#"), f"{figure}: no link to docs/results.md"
    anchor = target.group(1).split("#", 1)[1]
    assert anchor in headings(RESULTS), f"docs/results.md has no heading #{anchor}"
    text = section(RESULTS, anchor)
    for number in NUMBER.findall(plain(value)):
        assert number in text, f"{number} of {value!r} is not in docs/results.md#{anchor}"
    assert command.startswith("`") and command.strip("`") in text, f"{command} is not in docs/results.md#{anchor}"


def documents() -> list[Path]:
    return [README, *sorted((ROOT / "docs").glob("*.md"))]


@pytest.mark.parametrize("path", documents(), ids=lambda p: p.relative_to(ROOT).as_posix())
def test_links_stay_in_the_repository_and_find_their_target(path):
    text = re.sub(r"^```.*?^```", "", path.read_text(encoding="utf-8"), flags=re.MULTILINE | re.DOTALL)
    for target in LINK.findall(text):
        assert "://" not in target and not target.startswith("mailto:"), f"{path.name} links outside: {target}"
        file, _, anchor = target.partition("#")
        linked = (path.parent / file).resolve() if file else path
        assert linked.exists(), f"{path.name}: {target}: no such file"
        if anchor and linked.suffix == ".md":
            assert anchor in headings(linked), f"{path.name}: {target}: no such heading"


def sentences(path: Path) -> list[str]:
    """The sentences of ``path``'s prose, tables and bullets, code blocks left out."""
    text = re.sub(r"^```.*?^```", "", path.read_text(encoding="utf-8"), flags=re.MULTILINE | re.DOTALL)
    paragraphs = re.split(r"\n\s*\n|\n(?=\s*[*-] |#|\|)", text)
    return [s for p in paragraphs for s in re.split(r"(?<=[.;])\s+(?=[A-Z(*`\[])", " ".join(p.split()))]


@pytest.mark.parametrize("path", documents()[1:], ids=lambda p: p.relative_to(ROOT).as_posix())
def test_figures_that_cite_results_are_there(path):
    """A sentence that cites a section of docs/results.md states only decimal figures found in it."""
    for sentence in sentences(path):
        anchors = re.findall(r"\]\(results\.md#([\w-]+)\)", sentence)
        if path == RESULTS or not anchors:
            continue
        cited = "\n".join(section(RESULTS, anchor) for anchor in anchors)
        missing = {n for n in re.findall(r"(?<![\w.])\d+\.\d+(?![\w.])", LINK.sub("", sentence)) if n not in cited}
        assert not missing, f"{path.name}: {sorted(missing)} not in results.md#{', #'.join(anchors)}: {sentence[:200]}"


def table_one(row: str) -> float:
    pattern = rf"^\| \**{re.escape(row)}\** \| \**(\d+\.\d+)"
    match = re.search(pattern, RESULTS.read_text(encoding="utf-8"), flags=re.MULTILINE)
    assert match, f"docs/results.md's Table I has no row {row!r}"
    return float(match.group(1))


def test_mp_against_kajita_torque_is_the_same_everywhere():
    """Every "N % less than Kajita's" and "−N % against Kajita" is Table I's figure."""
    percent = round(100 * (1 - table_one("MP simulated") / table_one("Kajita simulated")))
    claims = []
    for path in documents():
        text = " ".join(path.read_text(encoding="utf-8").split())
        claims += re.findall(r"(\d+) % less than Kajita", text)
        claims += re.findall(r"[−-](\d+) % against Kajita", text)
        claims += re.findall(r"lower than Kajita's\**, by (\d+) %", text)
    readme_row = next(row for row in results_table() if "Kajita" in row[0])
    claims += re.findall(r"[−-](\d+) %", readme_row[1])
    assert claims and {int(claim) for claim in claims} == {percent}, (claims, percent)


def bundled_model_metadata() -> dict:
    with np.load(BUNDLED_MODEL, allow_pickle=False) as arrays:
        return json.loads(str(arrays["__metadata__"]))


def test_results_states_the_bundled_models_own_figures():
    meta = bundled_model_metadata()
    text = section(RESULTS, "model-selection")
    assert f"`training_wall_time_s` **{round(meta['training_wall_time_s'])} s**" in text
    variance = meta["explained_variance"]
    row = " | ".join(f"**{100 * variance[group]:.3f} %**" for group in ("joints", "zmp", "pelvis"))
    assert row in text, row


def test_the_python_example_prints_and_names_its_extra():
    text = README.read_text(encoding="utf-8").split("## Python API", 1)[1]
    prose, code = text.split("```python\n", 1)
    tree = ast.parse(code.split("```", 1)[0])
    bare = [node.lineno for node in tree.body if isinstance(node, ast.Expr) and not isinstance(node.value, ast.Call)]
    assert not bare, f"bare expressions (which print nothing) on lines {bare}"
    assert any(isinstance(node, ast.Call) and getattr(node.func, "id", None) == "print" for node in ast.walk(tree))
    assert "`MovementPrimitives.fit` needs the `[train]`" in " ".join(prose.split())


def test_the_latest_release_is_the_packages_version():
    from cocomopl import __version__

    changelog = (ROOT / "CHANGELOG.md").read_text(encoding="utf-8")
    releases = re.findall(r"^## \[(\d+\.\d+\.\d+)\] - (\d{4}-\d\d-\d\d)$", changelog, flags=re.MULTILINE)
    assert releases and releases[0][0] == __version__
    assert re.search(rf'^version = "{re.escape(__version__)}"$', (ROOT / "pyproject.toml").read_text(), flags=re.MULTILINE)
    citation = (ROOT / "CITATION.cff").read_text()
    assert f"version: {__version__}\n" in citation and f'date-released: "{releases[0][1]}"' in citation
