"""Holm's step-down adjustment, against values worked by hand."""

from __future__ import annotations

import pytest

from stook.sdk.stats import holm_adjusted


def test_holm_against_a_worked_example() -> None:
    # Sorted 0.01, 0.02, 0.03, 0.04 of four tests: 4x, 3x, 2x, 1x, made monotone.
    assert holm_adjusted([0.04, 0.01, 0.03, 0.02]) == pytest.approx([0.06, 0.04, 0.06, 0.06])


def test_holm_never_exceeds_one_and_keeps_the_order() -> None:
    p = [0.5, 0.001, 0.9, 0.2, 0.2]
    adjusted = holm_adjusted(p)
    assert all(a <= 1.0 for a in adjusted)
    assert all(a >= b for a, b in zip(adjusted, p, strict=True))
    ranked = sorted(range(len(p)), key=lambda i: p[i])
    assert [adjusted[i] for i in ranked] == sorted(adjusted)


def test_one_test_is_not_adjusted_and_none_is_nothing() -> None:
    assert holm_adjusted([0.03]) == [0.03]
    assert holm_adjusted([]) == []
