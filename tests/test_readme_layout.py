"""The README's layout section names the package's tree as it is: every sub-package and every
top-level module of ``src/resilient_tracking/``, and nothing that does not exist."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "resilient_tracking"
PACKAGE_LINE = "src/resilient_tracking/"


def layout_block(readme: str) -> list[str]:
    """The lines of the first fenced block under the README's ``## Layout`` heading."""
    section = re.search(r"^## Layout\n(.*?)(?=^## |\Z)", readme, re.M | re.S)
    assert section, "the README has no '## Layout' section"
    block = re.search(r"^```[^\n]*\n(.*?)^```", section.group(1), re.M | re.S)
    assert block, "the README's layout section has no fenced block"
    return block.group(1).splitlines()


def entries(lines: list[str]) -> tuple[list[str], list[str]]:
    """(top-level entries, package entries): the first word of each line that starts in column
    0, and of each line indented by exactly two spaces (the package's folders and modules)."""
    top, package = [], []
    for line in lines:
        if not line.strip():
            continue
        if re.match(r"\S", line):
            top.append(line.split()[0])
        elif re.match(r"  \S", line):
            package.append(line.split()[0])
    return top, package


def package_tree() -> set[str]:
    """Sub-packages (``name/``, folders with an ``__init__.py``) and top-level modules
    (``name.py``) of the package."""
    folders = {f"{p.parent.name}/" for p in PACKAGE.glob("*/__init__.py")}
    modules = {p.name for p in PACKAGE.glob("*.py") if p.name != "__init__.py"}
    return folders | modules


@pytest.fixture(scope="module")
def layout() -> tuple[list[str], list[str]]:
    return entries(layout_block((ROOT / "README.md").read_text(encoding="utf-8")))


def test_the_layout_names_every_subpackage_and_module_once(layout):
    _, package = layout
    assert len(package) == len(set(package)), "an entry is listed twice"
    missing = package_tree() - set(package)
    assert not missing, f"README layout misses {sorted(missing)}"


def test_the_layout_names_nothing_that_does_not_exist(layout):
    top, package = layout
    extra = set(package) - package_tree()
    assert not extra, f"README layout names {sorted(extra)}, not in src/resilient_tracking/"
    assert PACKAGE_LINE in top, "the package's entries must follow its own line"
    absent = [name for name in top if not (ROOT / name.rstrip("/")).exists()]
    assert not absent, f"README layout names {absent}, not in the repository"


def test_the_parser_sees_drift():
    lines = [PACKAGE_LINE + "   the package", "  world/   truth", "    more about it", "docs/  d"]
    assert entries(lines) == ([PACKAGE_LINE, "docs/"], ["world/"])
    assert "cli.py" in package_tree() or "cli/" in package_tree()
    assert "nothing/" not in package_tree()
