"""Text from the person's files and arguments reaches the terminal escaped
(docs/reliability.md §10)."""

from __future__ import annotations

import logging
import os

import yaml

from helpers import SCENARIOS
from resilient_tracking.cli import _ShownFormatter, main, shown

#: What a terminal acts on instead of showing: a window title, a colour, a right-to-left override.
HOSTILE = "evil\x1b]0;pwned\x07\x1b[31mRED\u202e"
ACTIVE = ("\x1b", "\x07", "\u202e")  # the progress bar itself writes "\\r"


def one_error_line(err: str) -> str:
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), err
    return lines[0]


def test_shown_escapes_what_a_terminal_would_act_on():
    assert shown("sensing-temp ü → 1") == "sensing-temp ü → 1"
    assert shown(HOSTILE) == "evil\\x1b]0;pwned\\x07\\x1b[31mRED\\u202e"
    assert shown("a\rb\tc") == "a\\rb\tc"
    assert shown(os.fsdecode(b"out\xff\xfe")) == "out\\xff\\xfe"  # bytes that are not UTF-8
    assert shown("two\nlines") == "two\\nlines"
    assert shown("two\nlines", lines=True) == "two\nlines"


def test_log_lines_are_escaped_like_printed_text():
    record = logging.LogRecord("x", logging.WARNING, "", 0, "zone %s", (HOSTILE,), None)
    line = _ShownFormatter("%(levelname)s %(message)s").format(record)
    assert line == "WARNING zone evil\\x1b]0;pwned\\x07\\x1b[31mRED\\u202e"


def test_a_scenario_name_with_escape_codes_reaches_the_terminal_escaped(tmp_path, capsys):
    data = yaml.safe_load((SCENARIOS / "sensing-temp.yaml").read_text())
    data["name"] = HOSTILE
    path = tmp_path / f"{HOSTILE}.yaml"
    path.write_text(yaml.safe_dump(data))
    assert main(["validate", str(path)]) == 0
    out = tmp_path / "out"
    assert main(["run", str(path), "--steps", "2", "--no-figures", "--out", str(out)]) == 0
    data["dt"] = "x"
    path.write_text(yaml.safe_dump(data))
    assert main(["validate", str(path)]) == 1
    printed = capsys.readouterr()
    text = printed.out + printed.err
    assert not [c for c in ACTIVE if c in text], text
    assert "evil\\x1b]0;pwned\\x07\\x1b[31mRED\\u202e [failure_aware]" in printed.err  # the bar
    assert "evil\\x1b]0;pwned\\x07\\x1b[31mRED\\u202e.yaml: ok" in printed.out
