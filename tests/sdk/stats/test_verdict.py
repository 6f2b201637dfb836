"""The verdict: direction, significance, the minimum effect, and inconclusive data."""

from __future__ import annotations

import math

import pytest

from stook.sdk.stats import ComparisonVerdict as V
from stook.sdk.stats import comparison_verdict


def verdict(estimate: float, low: float, high: float, significant: bool, **kw: object) -> V:
    options: dict[str, object] = {"level": 1.0, "better": "lower", "min_effect": 0.05} | kw
    return comparison_verdict(
        estimate=estimate,
        low=low,
        high=high,
        significant=significant,
        **options,  # type: ignore[arg-type]
    )


@pytest.mark.parametrize(
    ("estimate", "better", "expected"),
    [
        (0.2, "lower", V.REGRESSED),
        (-0.2, "lower", V.IMPROVED),
        (0.2, "higher", V.IMPROVED),
        (-0.2, "higher", V.REGRESSED),
        (0.2, None, V.CHANGED),
    ],
)
def test_a_significant_change_has_its_direction(
    estimate: float, better: str | None, expected: V
) -> None:
    assert verdict(estimate, estimate - 0.1, estimate + 0.1, True, better=better) is expected
    assert expected.is_alarm


def test_a_significant_change_below_the_minimum_effect_is_no_change() -> None:
    assert verdict(0.03, 0.01, 0.05, True) is V.NO_CHANGE
    assert verdict(0.03, 0.01, 0.05, True, level=-1.0) is V.NO_CHANGE  # |level| counts
    assert verdict(0.03, 0.01, 0.05, True, min_effect=0.0) is V.REGRESSED
    assert not V.NO_CHANGE.is_alarm


def test_not_significant_is_no_change_only_when_the_interval_rules_out_relevant_changes() -> None:
    assert verdict(0.01, -0.02, 0.04, False) is V.NO_CHANGE  # within +-5 % of the level
    assert verdict(0.01, -0.2, 0.3, False) is V.INCONCLUSIVE  # could hide a 20 % change
    assert verdict(0.01, -0.2, 0.3, False, min_effect=0.0) is V.NO_CHANGE
    assert verdict(0.0, -math.inf, math.inf, False) is V.INCONCLUSIVE
    assert not V.INCONCLUSIVE.is_alarm


def test_a_zero_estimate_is_never_a_change() -> None:
    assert verdict(0.0, 0.0, 0.0, True, min_effect=0.0) is V.NO_CHANGE
