"""The scenario reference is generated from the schema: complete, described and up to date."""

from __future__ import annotations

from pathlib import Path

from resilient_tracking.policies.failure_aware_params import FailureAwareParams
from resilient_tracking.policies.vanilla import VanillaParams
from resilient_tracking.scenario_reference import render, sections

REFERENCE = Path(__file__).resolve().parents[1] / "docs" / "scenario-reference.md"


def test_every_field_has_a_description():
    missing = [
        f"{s.path or '<top>'}.{name}"
        for s in sections()
        for name, field in s.model.model_fields.items()
        if not (field.description or "").strip()
    ]
    assert not missing, f"fields without Field(description=...): {missing}"


def test_committed_reference_is_the_generated_one():
    assert REFERENCE.read_text() == render(), (
        "docs/scenario-reference.md is stale: "
        "python -m resilient_tracking.scenario_reference > docs/scenario-reference.md"
    )


def _row(text: str, heading: str, field: str) -> str:
    section = text.split(f"## `{heading}`\n", 1)[1].split("\n## ", 1)[0]
    (row,) = [line for line in section.splitlines() if line.startswith(f"| `{field}` |")]
    return row


def test_every_policy_parameter_appears_with_the_codes_default():
    text = render()
    for name, field in FailureAwareParams.model_fields.items():
        row = _row(text, "policy.failure_aware", name)
        if isinstance(field.default, bool):  # written as YAML writes it
            assert f"`{str(field.default).lower()}`" in row, row
        elif isinstance(field.default, int | float):
            assert f"`{field.default}`" in row, row
    assert "`50.0`" in _row(text, "policy.vanilla", "w_track")
    assert VanillaParams().w_track == 50.0
    risky = _row(text, "policy.failure_aware", "risky")
    assert "track: 50.0" in risky and "sensing_slack: 200.0" in risky
    for name in ("window", "min_samples", "min_arc", "silent_steps"):
        _row(text, "belief.circle_fit", name)
