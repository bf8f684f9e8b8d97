"""EN-05's accuracy budget in its config (study.sensitivity.budget): on by default, refused
in one line naming the key when out of range, and off (null) leaving the config text, its
hash and the sample's name as they were before budgets existed."""

from __future__ import annotations

import hashlib
import json

import pytest

from creatio.errors import ConfigError
from creatio.pipeline import points
from creatio.pipeline.config import resolve


def test_the_budget_is_on_by_default_with_the_issue_s_fraction():
    """1e-3 of each output's standard deviation, a pilot of 16 points."""
    b = resolve("en05").obj.study.sensitivity.budget
    assert (b.fraction, b.points) == (1e-3, 16) and 0.0 < b.loosest_rtol < 1.0


@pytest.mark.parametrize(("override", "key", "rule"), [
    ("study.sensitivity.budget.fraction=0", "study.sensitivity.budget.fraction", "(0, 1)"),
    ("study.sensitivity.budget.fraction=1.5", "study.sensitivity.budget.fraction", "(0, 1)"),
    ("study.sensitivity.budget.loosest_rtol=2", "study.sensitivity.budget.loosest_rtol",
     "(0, 1)"),
    ("study.sensitivity.budget.points=8", "study.sensitivity.budget.points", ">= 16"),
    ("study.sensitivity.budget.points=1000000", "study.sensitivity.budget.points",
     "more than 200,000"),
])
def test_a_budget_out_of_range_is_refused_naming_its_key(override, key, rule):
    """One line, the key, the value's rule."""
    with pytest.raises(ConfigError) as info:
        resolve("en05", [override])
    assert info.value.key == key and rule in str(info.value) and "\n" not in str(info.value)


def test_budget_null_keeps_the_config_text_and_the_sample_name_of_before():
    """Off, the budget is absent from the resolved YAML (so its sha256 is the config's
    without the key), and the sample is named by the spec without a budget; on, the name
    changes with the budget's settings."""
    off = resolve("en05", ["study.sensitivity.budget=null"])
    on = resolve("en05")
    assert "budget" not in off.data["study"]["sensitivity"]
    assert "budget:" in on.yaml and "budget:" not in off.yaml
    sample = points.en05_sample(off)
    spec = {"study": "en02", "base": list(points.base_overrides(off)),
            "inputs": off.data["uncertainty"]["inputs"], "N": 512, "seed": 5}
    digest = hashlib.sha256(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:12]
    assert sample.name == f"en02-{digest}" and sample.budget is None
    other = resolve("en05", ["study.sensitivity.budget.fraction=1e-2"])
    names = {sample.name, points.en05_sample(on).name, points.en05_sample(other).name}
    assert len(names) == 3
