"""The README, the docs and the package's code describe what the software does, in the present
tense: no work history.

History belongs in CHANGELOG.md and docs/experiments/, which this test leaves out.  It scans
README.md, docs/*.md and every .py under cocomopl/, benchmarks/ and scripts/ (code, comments
and docstrings) for words that only a work diary uses: sessions, issue numbers, "in
progress", "until now", "previously", "earlier releases", "no longer", ...  Markdown link
targets are left out, so a link may point at an experiment's heading that names its session.
"""

import re
from pathlib import Path

ROOT = Path(__file__).parents[1]

HISTORY_WORDS = (
    r"\bsessions?\b",
    r"\bissues?\s*#\s*\d+",
    r"\bissues?\s+\d+\b",
    r"(?<![\w&/#\"'])#\d+\b",  # "#25's range"; a colour such as "#333" is quoted
    r"\bin progress\b",
    r"\buntil now\b",
    r"\bpreviously\b",
    r"\b(?:earlier|previous|this|last) releases?\b",
    r"\bno longer\b",
    r"\bsince (?:session|release|version|commit)\b",
    r"\bformerly\b",
    r"\bas of (?:now|today)\b",
    r"\btoday'?s?\b",
    r"\bprevious (?:dataset|model|bundled)\b",
)
HISTORY = re.compile("|".join(HISTORY_WORDS), flags=re.IGNORECASE)
LINK_TARGET = re.compile(r"\]\([^)]*\)")


def scanned_files() -> list[Path]:
    code = [path for folder in ("cocomopl", "benchmarks", "scripts") for path in sorted((ROOT / folder).rglob("*.py"))]
    return [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), *code]


def history_words(path: Path) -> list[str]:
    """``file:line: word`` for every history word in ``path``."""
    found = []
    for number, line in enumerate(path.read_text(encoding="utf-8").splitlines(), start=1):
        text = LINK_TARGET.sub("]()", line) if path.suffix == ".md" else line
        found += [f"{path.relative_to(ROOT)}:{number}: {match.group(0)!r}" for match in HISTORY.finditer(text)]
    return found


def test_the_scan_covers_the_readme_docs_and_package():
    names = {path.relative_to(ROOT).as_posix() for path in scanned_files()}
    assert {"README.md", "docs/results.md", "docs/method.md", "cocomopl/cli.py"} <= names
    assert not any(name.startswith("docs/experiments/") for name in names)


def test_the_pattern_finds_history_and_passes_present_tense():
    diary = ["Measured in session 35.", "Omnidirectional walking (issue #25, in progress)", "as in issue 24",
             "Until now it read the gap", "It previously refused M_gen", "earlier releases measured 93 µs",
             "the arms no longer swing", "since session 38", "with today's OCPs", "over #25's whole range",
             "the previous dataset's model"]
    present = ["The gate checks what is written.", "an issue with the contact model", "the previous step's torques",
               "a colour such as \"#333\"", "solved now, in the same run"]
    assert all(HISTORY.search(text) for text in diary)
    assert not any(HISTORY.search(text) for text in present)


def test_no_work_history_outside_the_changelog_and_experiments():
    found = [hit for path in scanned_files() for hit in history_words(path)]
    assert not found, "work history in the present-tense docs or code:\n" + "\n".join(found)
