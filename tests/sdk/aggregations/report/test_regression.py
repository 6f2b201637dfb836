"""The regression check of report lines: a robust baseline (median and MAD) of the values
before the latest one, exact values on hand-made series and properties on random ones."""

from __future__ import annotations

import math
from collections.abc import Sequence

import pytest
from hypothesis import assume, given
from hypothesis import strategies as st

from stook.sdk.aggregations.report import Verdict, check
from stook.sdk.aggregations.report._change_points import MAD_TO_SIGMA, MIN_BASELINE, RELATIVE_FLOOR
from tests.hypothesis_profiles import examples


def reference_median(values: Sequence[float]) -> float:
    s = sorted(values)
    mid = len(s) // 2
    return s[mid] if len(s) % 2 else (s[mid - 1] + s[mid]) / 2


def reference_deviations(values: Sequence[float], window: int) -> tuple[float, float, float]:
    """(median, MAD, deviations) of the last value against up to `window` values before it."""
    baseline = list(values[:-1])[-window:]
    median = reference_median(baseline)
    mad = reference_median([abs(v - median) for v in baseline])
    scale = max(1.4826 * mad, 0.02 * abs(median), 1e-12)
    return median, mad, abs(values[-1] - median) / scale


# ---------------------------------------------------------------- exact verdicts


def test_the_constants_are_the_documented_ones() -> None:
    assert (MAD_TO_SIGMA, RELATIVE_FLOOR, MIN_BASELINE) == (1.4826, 0.02, 3)


def test_a_stable_series_is_not_flagged() -> None:
    v = check([10.0, 10.5, 9.5, 10.0, 10.25], window=10, threshold=3.5)
    assert v.regressed is False
    assert v.latest == 10.25
    assert v.baseline_median == 10.0
    assert v.baseline_mad == 0.25  # |deviations| 0, 0.5, 0.5, 0
    assert v.baseline_size == 4
    assert v.deviations == pytest.approx(0.25 / (1.4826 * 0.25))
    assert v.reason == ""
    assert v.change == 0.25
    assert v.relative_change == pytest.approx(0.025)


def test_a_jump_is_flagged_with_its_deviations_median_and_mad() -> None:
    v = check([10.0, 10.5, 9.5, 10.0, 20.0], window=10, threshold=3.5)
    assert v == Verdict(
        True,
        20.0,
        baseline_median=10.0,
        baseline_mad=0.25,
        deviations=10.0 / 0.37065,
        baseline_size=4,
    )
    assert v.deviations == pytest.approx(26.98, abs=0.01)
    assert v.change == 10.0
    assert v.relative_change == 1.0


def test_a_drop_is_flagged_like_a_jump() -> None:
    up = check([10.0, 10.5, 9.5, 10.0, 20.0], window=10, threshold=3.5)
    down = check([10.0, 10.5, 9.5, 10.0, 0.0], window=10, threshold=3.5)
    assert down.regressed is True
    assert down.deviations == up.deviations
    assert down.change == -10.0
    assert down.relative_change == -1.0


def test_the_median_and_mad_ignore_a_wild_value_in_the_baseline() -> None:
    # A mean and standard deviation would be dragged to ~208 and ~440 by the 1000.
    v = check([10.0, 11.0, 9.0, 1000.0, 10.0, 13.0], window=10, threshold=3.5)
    assert v.baseline_median == 10.0
    assert v.baseline_mad == 1.0  # |deviations| 0, 1, 1, 990, 0
    assert v.deviations == pytest.approx(3.0 / 1.4826)
    assert v.regressed is False


def test_the_window_limits_the_baseline_to_the_last_values() -> None:
    values = [50.0] * 5 + [10.0, 11.0, 9.0, 10.0] + [12.0]
    near = check(values, window=4, threshold=3.5)
    assert near.baseline_size == 4
    assert near.baseline_median == 10.0
    assert near.baseline_mad == 0.5
    assert near.deviations == pytest.approx(2.0 / (1.4826 * 0.5))
    assert near.regressed is False

    far = check(values, window=9, threshold=3.5)
    # sorted baseline 9, 10, 10, 11, 50 x 5: median 50; |deviations| 0 x 5, 39, 40, 40, 41
    assert far.baseline_size == 9
    assert far.baseline_median == 50.0
    assert far.baseline_mad == 0.0
    assert far.deviations == 38.0  # the 2% floor: 1.0
    assert far.regressed is True

    # A window longer than the series takes every earlier value.
    assert check(values, window=100, threshold=3.5) == far


def test_a_window_of_one_value_gives_no_verdict() -> None:
    v = check([1.0, 2.0, 3.0, 4.0, 100.0], window=2, threshold=3.5)
    assert v.regressed is None
    assert v.baseline_size == 2
    assert v.reason == "2 earlier batches; at least 3 are needed"


@pytest.mark.parametrize("earlier", [0, 1, 2])
def test_fewer_than_three_earlier_values_give_no_verdict(earlier: int) -> None:
    values = [float(i) for i in range(earlier)] + [1e9]
    v = check(values, window=10, threshold=3.5)
    assert v == Verdict(
        None,
        1e9,
        baseline_size=earlier,
        reason=f"{earlier} earlier batches; at least 3 are needed",
    )


def test_three_earlier_values_are_enough() -> None:
    v = check([1.0, 2.0, 3.0, 100.0], window=10, threshold=3.5)
    assert v.regressed is True
    assert (v.baseline_size, v.baseline_median, v.baseline_mad) == (3, 2.0, 1.0)


def test_no_values_is_an_error() -> None:
    with pytest.raises(ValueError, match="no values to check"):
        check([], window=10, threshold=3.5)


def test_a_flat_baseline_uses_the_two_percent_floor() -> None:
    # MAD 0: the scale is 2% of |median| = 2, so 7 away is 3.5 deviations, 8 away 4.
    at = check([100.0, 100.0, 100.0, 107.0], window=10, threshold=3.5)
    assert at.baseline_mad == 0.0
    assert at.deviations == 3.5
    assert at.regressed is False  # exactly at the threshold is not past it
    past = check([100.0, 100.0, 100.0, 108.0], window=10, threshold=3.5)
    assert past.deviations == 4.0
    assert past.regressed is True
    same = check([100.0, 100.0, 100.0, 100.0], window=10, threshold=3.5)
    assert (same.deviations, same.regressed) == (0.0, False)


def test_the_floor_applies_when_the_mad_is_small_but_not_zero() -> None:
    # MAD 0.5 -> 0.7413 < 2% of 1000 = 20: the floor wins.
    v = check([1000.0, 1001.0, 999.0, 1000.0, 1050.0], window=10, threshold=3.5)
    assert v.baseline_mad == 0.5
    assert v.deviations == 2.5
    assert v.regressed is False


def test_a_negative_median_uses_its_magnitude_for_the_floor() -> None:
    at = check([-100.0, -101.0, -99.0, -100.0, -100.0, -107.0], window=10, threshold=3.5)
    assert at.baseline_median == -100.0
    assert at.baseline_mad == 0.0  # |deviations| 0, 1, 1, 0, 0
    assert at.deviations == 3.5
    assert at.regressed is False
    past = check([-100.0, -101.0, -99.0, -100.0, -100.0, -92.0], window=10, threshold=3.5)
    assert past.deviations == 4.0
    assert past.regressed is True
    assert past.change == 8.0
    assert past.relative_change == 0.08  # relative to |median|: up is positive


def test_a_zero_median_with_zero_mad_uses_the_tiny_absolute_floor() -> None:
    flat = check([0.0, 0.0, 0.0, 0.0], window=10, threshold=3.5)
    assert (flat.regressed, flat.deviations, flat.relative_change) == (False, 0.0, None)
    tiny = check([0.0, 0.0, 0.0, 3e-12], window=10, threshold=3.5)
    assert tiny.deviations == pytest.approx(3.0)
    assert tiny.regressed is False
    moved = check([0.0, 0.0, 0.0, 1e-9], window=10, threshold=3.5)
    assert moved.deviations == pytest.approx(1000.0)
    assert moved.regressed is True
    assert moved.relative_change is None
    assert moved.change == 1e-9


def test_a_zero_median_with_spread_uses_the_mad() -> None:
    v = check([-2.0, 0.0, 2.0, 0.0, 9.0], window=10, threshold=3.5)
    assert (v.baseline_median, v.baseline_mad) == (0.0, 1.0)  # |deviations| 2, 0, 2, 0
    assert v.deviations == pytest.approx(9.0 / 1.4826)
    assert v.regressed is True
    assert v.relative_change is None


def test_the_threshold_boundary_just_below_and_just_above() -> None:
    baseline = [0.0, 1.0, 2.0]  # median 1, MAD 1, scale 1.4826
    boundary = 1.0 + 3.5 * 1.4826
    below = check([*baseline, boundary - 1e-9], window=10, threshold=3.5)
    above = check([*baseline, boundary + 1e-9], window=10, threshold=3.5)
    assert below.regressed is False
    assert above.regressed is True
    assert below.deviations < 3.5 < above.deviations
    assert below.deviations == pytest.approx(3.5)
    assert above.deviations == pytest.approx(3.5)

    # At the float level: exactly the deviations is not past, one ulp less is.
    exact = check([*baseline, boundary], window=10, threshold=3.5).deviations
    assert check([*baseline, boundary], window=10, threshold=exact).regressed is False
    one_ulp_less = math.nextafter(exact, 0.0)
    assert check([*baseline, boundary], window=10, threshold=one_ulp_less).regressed is True


@pytest.mark.parametrize("threshold", [1.0, 3.5, 10.0])
def test_the_threshold_decides(threshold: float) -> None:
    # 4 away from a median of 10 with MAD 1: 2.698 deviations.
    v = check([9.0, 10.0, 11.0, 14.0], window=10, threshold=threshold)
    assert v.deviations == pytest.approx(4.0 / 1.4826)
    assert v.regressed is (threshold < 4.0 / 1.4826)


@pytest.mark.parametrize("latest", [math.inf, -math.inf, math.nan])
def test_a_non_finite_latest_value_gives_no_verdict(latest: float) -> None:
    v = check([1.0, 2.0, 3.0, 4.0, latest], window=10, threshold=3.5)
    assert v.regressed is None
    assert v.reason == "the latest value is not a finite number"
    assert v.baseline_size == 0
    assert v.latest is latest


def test_non_finite_values_are_left_out_of_the_baseline() -> None:
    values = [math.inf, 10.0, 11.0, math.nan, 9.0, -math.inf, 10.0, 14.0]
    v = check(values, window=10, threshold=3.5)
    assert (v.baseline_size, v.baseline_median, v.baseline_mad) == (4, 10.0, 0.5)
    assert v.deviations == pytest.approx(4.0 / (1.4826 * 0.5))
    assert v.regressed is True
    assert v == check([10.0, 11.0, 9.0, 10.0, 14.0], window=10, threshold=3.5)


def test_an_all_infinite_baseline_gives_no_verdict() -> None:
    v = check([math.inf, math.inf, math.inf, 1.0], window=10, threshold=3.5)
    assert v.regressed is None
    assert v.baseline_size == 0
    assert v.reason == "0 earlier batches; at least 3 are needed"


def test_the_window_counts_batches_before_leaving_out_non_finite_ones() -> None:
    # The window of 3 holds 2, 3 and inf: two finite values are too few.
    v = check([1.0, 2.0, 3.0, math.inf, 100.0], window=3, threshold=3.5)
    assert v.regressed is None
    assert v.baseline_size == 2


# ---------------------------------------------------------------- properties

FAST = examples(40)

# Integers (as floats) keep medians, MADs and differences exact, so that a shift or a
# power-of-two scale leaves the deviations bit for bit the same.
integer_values = st.lists(
    st.integers(-10_000, 10_000).map(float), min_size=MIN_BASELINE + 1, max_size=14
)
windows = st.integers(1, 14)
thresholds = st.sampled_from([1.0, 2.0, 3.5, 5.0])


@FAST
@given(values=integer_values, window=windows, threshold=thresholds)
def test_check_matches_an_independent_computation(
    values: list[float], window: int, threshold: float
) -> None:
    v = check(values, window=window, threshold=threshold)
    size = min(window, len(values) - 1)
    assert v.baseline_size == size
    assert v.latest == values[-1]
    if size < MIN_BASELINE:
        assert v.regressed is None
        return
    median, mad, deviations = reference_deviations(values, window)
    assert (v.baseline_median, v.baseline_mad) == (median, mad)
    assert v.deviations == pytest.approx(deviations, rel=1e-12)
    assert v.regressed is (v.deviations > threshold)


@FAST
@given(window=windows, extra=st.lists(st.integers(-99, 99).map(float), min_size=1), data=st.data())
def test_only_the_last_window_values_matter(
    window: int, extra: list[float], data: st.DataObject
) -> None:
    tail = data.draw(
        st.lists(st.integers(-10_000, 10_000).map(float), min_size=window + 1, max_size=16)
    )
    tail = tail[-window - 1 :]
    assert check(extra + tail, window=window, threshold=3.5) == check(
        tail, window=window, threshold=3.5
    )


def _mad_dominates(values: Sequence[float], window: int) -> bool:
    """Whether 1.4826 x MAD clearly exceeds the 2% floor, so that only the MAD sets the scale."""
    median, mad, _ = reference_deviations(values, window)
    return MAD_TO_SIGMA * mad > 1.01 * RELATIVE_FLOOR * abs(median)


@FAST
@given(
    values=integer_values,
    window=st.integers(MIN_BASELINE, 14),
    shift=st.integers(-20_000, 20_000).map(float),
    threshold=thresholds,
)
def test_adding_a_constant_does_not_change_the_verdict(
    values: list[float], window: int, shift: float, threshold: float
) -> None:
    # Only while the MAD sets the scale: the 2% floor follows the median, not the spread.
    shifted = [v + shift for v in values]
    assume(_mad_dominates(values, window) and _mad_dominates(shifted, window))
    a = check(values, window=window, threshold=threshold)
    b = check(shifted, window=window, threshold=threshold)
    assert b.regressed is a.regressed
    assert b.deviations == a.deviations
    assert b.baseline_mad == a.baseline_mad
    assert b.baseline_median == a.baseline_median + shift
    assert b.change == a.change


@FAST
@given(
    values=integer_values,
    window=st.integers(MIN_BASELINE, 14),
    factor=st.floats(min_value=1e-3, max_value=1e3),
    threshold=thresholds,
)
def test_scaling_by_a_positive_factor_does_not_change_the_verdict(
    values: list[float], window: int, factor: float, threshold: float
) -> None:
    a = check(values, window=window, threshold=threshold)
    # The 1e-12 absolute floor (zero median and zero MAD) does not scale.
    assume(a.baseline_median != 0.0 or a.baseline_mad != 0.0)
    # Within rounding of the threshold a verdict may go either way.
    assume(abs(a.deviations - threshold) > 1e-9 * threshold)
    b = check([v * factor for v in values], window=window, threshold=threshold)
    assert b.regressed is a.regressed
    assert b.deviations == pytest.approx(a.deviations, rel=1e-12, abs=1e-12)
    assert b.baseline_median == pytest.approx(a.baseline_median * factor, rel=1e-12)
    assert b.baseline_mad == pytest.approx(a.baseline_mad * factor, rel=1e-12)


@FAST
@given(
    values=integer_values,
    window=st.integers(MIN_BASELINE, 14),
    power=st.integers(-20, 20),
    threshold=thresholds,
)
def test_scaling_by_a_power_of_two_is_exact(
    values: list[float], window: int, power: int, threshold: float
) -> None:
    a = check(values, window=window, threshold=threshold)
    assume(a.baseline_median != 0.0 or a.baseline_mad != 0.0)
    b = check([math.ldexp(v, power) for v in values], window=window, threshold=threshold)
    assert b.regressed is a.regressed
    assert b.deviations == a.deviations
    assert b.baseline_median == math.ldexp(a.baseline_median, power)
    assert b.relative_change == a.relative_change
