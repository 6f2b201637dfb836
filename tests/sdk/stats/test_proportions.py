"""Wilson and Newcombe intervals against scipy and against Newcombe (1998)'s own table."""

from __future__ import annotations

import pytest
from scipy.stats import binomtest

from stook.sdk.stats import newcombe_difference, normal_quantile, wilson_interval


@pytest.mark.parametrize(
    ("k", "n"), [(0, 1), (1, 1), (0, 10), (3, 10), (10, 10), (81, 263), (15, 148), (199, 200)]
)
@pytest.mark.parametrize("confidence", [0.9, 0.95, 0.99])
def test_wilson_matches_scipy(k: int, n: int, confidence: float) -> None:
    ours = wilson_interval(k, n, confidence)
    theirs = binomtest(k, n).proportion_ci(confidence_level=confidence, method="wilson")
    assert ours.estimate == k / n
    assert ours.low == pytest.approx(theirs.low, abs=1e-12)
    assert ours.high == pytest.approx(theirs.high, abs=1e-12)


# Newcombe, "Interval estimation for the difference between independent proportions:
# comparison of eleven methods", Statistics in Medicine 17 (1998), Table II, method 10.
NEWCOMBE_1998 = [
    ((56, 70, 48, 80), (0.0524, 0.3339)),
    ((9, 10, 3, 10), (0.1705, 0.8090)),
    ((6, 7, 2, 7), (0.0582, 0.8062)),
    ((5, 56, 0, 29), (-0.0381, 0.1926)),
]


@pytest.mark.parametrize(("counts", "published"), NEWCOMBE_1998)
def test_newcombe_matches_the_published_table(
    counts: tuple[int, int, int, int], published: tuple[float, float]
) -> None:
    interval = newcombe_difference(*counts)
    a, n, b, m = counts
    assert interval.estimate == pytest.approx(a / n - b / m)
    assert (round(interval.low, 4), round(interval.high, 4)) == published


def test_newcombe_is_antisymmetric_and_contains_its_estimate() -> None:
    one = newcombe_difference(30, 40, 20, 45)
    other = newcombe_difference(20, 45, 30, 40)
    assert one.low == pytest.approx(-other.high)
    assert one.high == pytest.approx(-other.low)
    assert one.low < one.estimate < one.high
    assert one.excludes_zero() is (one.low > 0 or one.high < 0)


def test_a_wider_confidence_gives_a_wider_interval() -> None:
    narrow, wide = wilson_interval(7, 20, 0.9), wilson_interval(7, 20, 0.99)
    assert wide.low < narrow.low < narrow.high < wide.high
    assert normal_quantile(0.95) == pytest.approx(1.959963984540054)


@pytest.mark.parametrize(("k", "n"), [(1, 0), (-1, 3), (4, 3)])
def test_impossible_counts_are_refused(k: int, n: int) -> None:
    with pytest.raises(ValueError, match="successes"):
        wilson_interval(k, n)


@pytest.mark.parametrize("confidence", [0.0, 1.0, 1.5])
def test_confidence_must_lie_inside_zero_and_one(confidence: float) -> None:
    with pytest.raises(ValueError, match="confidence"):
        wilson_interval(1, 2, confidence)
