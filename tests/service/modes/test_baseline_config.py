"""[batch.baseline]: every bad value is refused naming it, before any request."""

from __future__ import annotations

import uuid
from typing import Any

import pytest

from stook.sdk.aggregations.baseline import BaselineComparison
from stook.service.modes import ConfigError
from stook.service.modes._batch import batch_aggregations
from stook.service.modes._config import parse

BATCH = "0b0b0b0b-1111-4222-8333-444444444444"


def baseline(**table: Any) -> dict[str, Any]:
    return {"batch": {"baseline": table}}


def test_a_full_table_parses() -> None:
    config = parse(
        baseline(
            branch=" main ",
            metrics=["Localization error", "Max speed"],
            better={"Max speed": "higher"},
            min_effect=0,
            confidence=0.9,
            correction="none",
            resamples=500,
            block_on_regression=True,
        )
    )
    settings = config.baseline
    assert settings is not None
    assert settings.branch == "main"
    assert (settings.batch, settings.previous) == (None, False)
    comparison = settings.comparison()
    assert isinstance(comparison, BaselineComparison)
    assert comparison.metrics == ("Localization error", "Max speed")
    assert comparison.better == {"Max speed": "higher"}
    assert (comparison.min_effect, comparison.confidence, comparison.resamples) == (0.0, 0.9, 500)
    assert comparison.correction == "none"
    assert comparison.block_on_regression


def test_defaults_and_the_other_two_choices() -> None:
    previous = parse(baseline(previous=True)).baseline
    named = parse(baseline(batch=BATCH)).baseline
    assert previous is not None
    assert named is not None
    assert previous.previous
    assert named.batch == uuid.UUID(BATCH)
    assert (previous.min_effect, previous.confidence, previous.correction) == (0.05, 0.95, "holm")
    assert parse({}).baseline is None


def test_the_comparison_joins_batch_mode_and_its_needs() -> None:
    config = parse(baseline(previous=True, metrics=["Max speed"]))
    aggregations = batch_aggregations(config)
    assert aggregations.comparison is not None
    assert aggregations.comparison in aggregations.all
    assert aggregations.comparison.needs().scalars == frozenset({"Max speed"})
    assert batch_aggregations(parse({})).comparison is None


@pytest.mark.parametrize(
    ("table", "message"),
    [
        ({}, "needs exactly one of batch, branch or previous"),
        ({"previous": True, "branch": "main"}, r"exactly one .* \(got branch, previous\)"),
        ({"batch": "not-a-uuid"}, "batch must be a batch ID"),
        ({"branch": ""}, "branch must be a branch name or ID"),
        ({"branch": 3}, "branch must be a branch name or ID"),
        ({"previous": False}, "previous must be true"),
        ({"previous": True, "metrics": []}, "metrics must be a non-empty list"),
        ({"previous": True, "metrics": "Max speed"}, "metrics must be a non-empty list"),
        ({"previous": True, "better": "lower"}, "better must be a table"),
        ({"previous": True, "better": {"Max speed": "up"}}, 'must be "lower" or "higher"'),
        (
            {"previous": True, "metrics": ["A"], "better": {"B": "lower"}},
            "better names 'B', which is not one of its metrics",
        ),
        ({"previous": True, "min_effect": -1}, "min_effect must be a number"),
        ({"previous": True, "min_effect": True}, "min_effect must be a number"),
        ({"previous": True, "confidence": 1.0}, "confidence must be a number from 0.5"),
        (
            {"previous": True, "resamples": 10},
            "resamples must be an integer from 100 to 100000, got 10",
        ),
        (
            {"previous": True, "resamples": 1000.0},
            "resamples must be an integer from 100 to 100000, got the float 1000.0",
        ),
        ({"previous": True, "correction": "bh"}, "correction must be one of holm, none"),
        ({"previous": True, "block_on_regression": "yes"}, "block_on_regression must be"),
        ({"previous": True, "treshold": 2}, "unknown key 'treshold' in \\[batch.baseline\\]"),
    ],
)
def test_bad_tables_are_refused_naming_the_key(table: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError, match=message) as caught:
        parse(baseline(**table), source="stook.toml")
    assert str(caught.value).startswith("stook.toml: [batch.baseline]") or "unknown key" in str(
        caught.value
    )


def test_a_list_of_baselines_is_refused() -> None:
    with pytest.raises(ConfigError, match=r"must be a table \(one \[batch.baseline\]"):
        parse({"batch": {"baseline": [{"previous": True}]}})
