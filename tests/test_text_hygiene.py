"""The text describes the software, not how it was made: no issue or pull-request numbers of this
project, and no numbered work sessions, in the code, the docs (not the generated docs/results),
the tests or the README."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TEXT = {".py", ".md", ".yaml", ".yml", ".toml", ".txt", ".cfg", ".msg"}

#: Phrases that point at a tracker entry or a work session instead of at the software.
FORBIDDEN = [
    # "issue 12", "issues #6", "Issue#15", "PR 3", "pull request #4"
    re.compile(r"\b(?:issues?|pr|pull[ -]requests?|tickets?)\s*#?\s*\d+\b", re.IGNORECASE),
    # "session 2", "round #3"
    re.compile(r"\bsession\s*#?\s*\d+\b", re.IGNORECASE),
    # a bare "#15" in prose; not a markdown anchor ("model.md#5-planning", "(#10-choices"), a
    # hex colour ("#1f77b4"), a URL fragment or an HTML entity
    re.compile(r"(?<![\w/.#&-])#\d{1,5}(?![\w-])"),
]


def checked_files() -> list[Path]:
    files = [ROOT / "README.md"]
    for folder in ("src", "docs", "tests"):
        for path in sorted((ROOT / folder).rglob("*")):
            if (
                path.is_file()
                and path.suffix in TEXT
                and "results" not in path.relative_to(ROOT / folder).parts[:1]
                and "__pycache__" not in path.parts
                and path != Path(__file__).resolve()  # its examples are offences on purpose
            ):
                files.append(path)
    return files


def offences(text: str) -> list[str]:
    out = []
    for number, line in enumerate(text.splitlines(), 1):
        for pattern in FORBIDDEN:
            for match in pattern.finditer(line):
                out.append(f"{number}: {match.group(0)!r} in {line.strip()[:100]!r}")
    return out


@pytest.mark.parametrize(
    ("text", "bad"),
    [
        ("see issue #6, item 3", True),
        ("the targets issue 12 sets", True),
        ("Issue#15: the cases", True),
        ("measured in session 2", True),
        ("fixed in PR 7", True),
        ("as asked in #15, the table", True),
        ("(#15)", True),
        ("see [model §5](model.md#5-planning)", False),
        ("[§10](#10-choices-where-the-paper-is-silent)", False),
        ('color="#1f77b4"', False),
        ("an issue with the solver, 3 times", False),
        ('scope="session"', False),
    ],
)
def test_the_patterns_catch_issue_numbers_and_spare_anchors(text, bad):
    assert bool(offences(text)) is bad


def test_the_checked_files_include_code_docs_tests_and_readme():
    names = {p.relative_to(ROOT).as_posix() for p in checked_files()}
    assert {"README.md", "docs/reliability.md", "src/resilient_tracking/cli/__init__.py"} <= names
    assert "tests/test_cli.py" in names
    assert not any(n.startswith("docs/results/") for n in names)


def test_no_issue_numbers_or_sessions_in_the_text():
    found = {}
    for path in checked_files():
        bad = offences(path.read_text(encoding="utf-8", errors="replace"))
        if bad:
            found[path.relative_to(ROOT).as_posix()] = bad
    assert not found, found
