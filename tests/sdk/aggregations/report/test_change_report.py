"""Change points in report aggregations: the level series on `N over time` lines and the
``Change points`` text with its failure-rate plot, on hand-made batches."""

from __future__ import annotations

import dataclasses
import uuid

import pytest

from stook.sdk import MetricStatus
from stook.sdk.aggregations import BatchRecord, Scalar
from stook.sdk.aggregations.report import ChangePoints, ScalarLines
from stook.sdk.aggregations.report._change_points import (
    Shift,
    fitted_levels,
    level_shifts,
    noise_scale,
    rate_shifts,
)
from tests.sdk.aggregations.report.support import Output, batch, fold, scrambled

# A line that sits near 100 for 7 batches and near 130 from batch 7 on (x 1.3), with
# noise of about 1 %; and experience "e" that starts failing at batch 7.
NOISE = [0.4, -0.9, 0.2, 1.1, -0.3, 0.6, -0.5, 0.8, -1.0, 0.1, 0.7, -0.6]
STEP = 7
BUILD = uuid.UUID("12345678-9abc-4def-8123-456789abcdef")


def _records(*, step: bool = True, failing: bool = True) -> list[BatchRecord]:
    out = []
    for i, noise in enumerate(NOISE):
        moved = step and i >= STEP
        fails = failing and i >= STEP
        record = batch(
            i,
            float(i),
            name=f"nightly-{i:02d}",
            scalars={
                "lat": Scalar((130.0 if moved else 100.0) + noise, "ms"),
                "flat": Scalar(50.0 + noise / 10),
            },
            jobs=[("e", "BLOCKER" if fails else "PASSED")] * 3
            + [("f", "PASSED"), ("f", "WARNING"), ("g", "CANCELLED")],
        )
        out.append(dataclasses.replace(record, build_id=BUILD if i == STEP else None))
    return out


def test_a_level_shift_is_found_with_its_levels() -> None:
    values = [(130.0 if i >= STEP else 100.0) + n for i, n in enumerate(NOISE)]
    (shift,) = level_shifts(values)
    assert shift.index == STEP
    assert shift.before == pytest.approx(sum(values[:STEP]) / STEP)
    assert shift.after == pytest.approx(sum(values[STEP:]) / (len(values) - STEP))
    assert shift.relative_change == pytest.approx(shift.change / shift.before)
    # Non-finite values are left out of the search; indices stay positions in the series.
    with_gap = [*values[:3], float("nan"), *values[3:]]
    (gapped,) = level_shifts(with_gap)
    assert gapped.index == STEP + 1
    assert level_shifts(values[:5]) == []  # too few batches
    assert level_shifts([3.0] * 10) == []  # constant
    assert level_shifts([0.0] * 10) == []


def test_fitted_levels_and_relative_change() -> None:
    shifts = [Shift(2, 1.0, 3.0), Shift(4, 3.0, 2.0)]
    assert fitted_levels(6, shifts) == [1.0, 1.0, 3.0, 3.0, 2.0, 2.0]
    assert fitted_levels(6, []) == []
    assert Shift(1, 0.0, 2.0).relative_change is None


def test_noise_scale_ignores_one_step() -> None:
    calm = [10.0 + n for n in NOISE]
    stepped = [v + (50.0 if i >= STEP else 0.0) for i, v in enumerate(calm)]
    assert noise_scale(stepped) == pytest.approx(noise_scale(calm), rel=0.35)
    assert noise_scale([1.0, 2.0]) == 0.0


def test_noise_scale_survives_values_near_the_float_maximum() -> None:
    # fsum's partials overflow on these (found by hypothesis): a report must not crash.
    huge = 1.7976931348623157e308
    assert noise_scale([0.0, huge, 0.0, huge]) > 1e307
    assert noise_scale([huge, 0.0, huge]) > 1e307


def test_a_failure_rate_shift() -> None:
    failed = [0, 0, 1, 0, 0, 0, 0, 3, 3, 3, 2, 3]
    (shift,) = rate_shifts(failed, [3] * 12)
    assert shift.index == STEP
    assert shift.before == pytest.approx(1 / 21)
    assert shift.after == pytest.approx(14 / 15)
    assert rate_shifts([0] * 12, [3] * 12) == []
    assert rate_shifts([3] * 12, [3] * 12) == []
    # Many experiences at once: a weaker move is no longer enough.
    weak = [0, 0, 0, 0, 0, 0, 1, 1, 1, 1, 0, 1]
    assert rate_shifts(weak, [1] * 12, factor=1.0)
    assert not rate_shifts(weak, [1] * 12, factor=1.0, series=1000)


def test_change_points_text_names_the_batch_build_and_levels() -> None:
    agg = fold(ChangePoints(), scrambled(_records()))
    assert isinstance(agg, ChangePoints)
    summary = agg.summary()
    assert summary is not None
    assert summary.status is MetricStatus.FAIL_WARN  # a failure rate rose
    kinds = [(m.kind, m.subject, m.batch.name, m.build_id) for m in summary.moves]
    assert kinds == [
        ("metric", "lat", "nightly-07", BUILD),
        ("failure rate", "e", "nightly-07", BUILD),
    ]
    out = Output(agg)
    text, status = out.text("Change points")
    assert status is MetricStatus.FAIL_WARN
    assert text.startswith(
        "2 change points in 1 of 2 batch metrics and 1 of 2 experiences' failure rates "
        "over 12 batches (nightly-00 to nightly-11):"
    ), text
    lat = summary.moves[0]
    assert (
        f"- 'lat' moved at nightly-07 (build 12345678, 2024-03-08 12:00 UTC): "
        f"{lat.before:.6g} ms → {lat.after:.6g} ms (+" in text
    )
    assert "- 'e' failure rate moved at nightly-07 (build 12345678, " in text
    assert "0% → 100% (+100 points)." in text
    assert "penalty 3 ln n + 8" in text
    # The failure-rate plot: one line for "e", the batch where it moved marked.
    (line,) = out.lines("Failure rate over time")
    assert line.y == [0.0] * STEP + [100.0] * (12 - STEP)
    assert line.statuses == ["PASSED"] * STEP + ["FAIL_WARN"] + ["PASSED"] * (11 - STEP)
    assert out.by_name["Failure rate over time"].status is MetricStatus.FAIL_WARN


def test_a_metric_move_alone_is_reported_not_judged() -> None:
    out = Output(fold(ChangePoints(), _records(failing=False)))
    text, status = out.text("Change points")
    assert status is MetricStatus.PASSED
    assert text.startswith("1 change point in 1 of 2 batch metrics and 0 of 2 experiences'")
    assert "Failure rate over time" not in out.names


def test_no_change_point_and_too_few_batches() -> None:
    text, status = Output(fold(ChangePoints(), _records(step=False, failing=False))).text(
        "Change points"
    )
    assert status is MetricStatus.PASSED
    assert text.startswith("No change point: no level moved in 0 of 2 batch metrics and 0 of 2")
    text, status = Output(fold(ChangePoints(), _records()[:5])).text("Change points")
    assert status is MetricStatus.NOT_APPLICABLE
    assert text == (
        "No change-point search: 5 batches (nightly-00 to nightly-04); at least 6 are needed."
    )
    assert Output(ChangePoints()).names == []


def test_experiences_can_be_left_out() -> None:
    out = Output(fold(ChangePoints(experiences=False), _records()))
    text, status = out.text("Change points")
    assert status is MetricStatus.PASSED
    assert "failure rate" not in text
    assert out.names == ["Change points"]


def test_the_penalty_is_read() -> None:
    strict = fold(ChangePoints(penalty=5000.0), _records())
    assert isinstance(strict, ChangePoints)
    summary = strict.summary()
    assert summary is not None
    assert summary.moves == ()
    with pytest.raises(ValueError, match="penalty"):
        ChangePoints(penalty=0.0)
    with pytest.raises(ValueError, match="top_n"):
        ChangePoints(top_n=0)


def test_order_in_time_matters() -> None:
    records = _records()
    reversed_times = [
        dataclasses.replace(r, created=records[-1 - i].created) for i, r in enumerate(records)
    ]
    a = Output(fold(ChangePoints(), records)).text("Change points")[0]
    b = Output(fold(ChangePoints(), reversed_times)).text("Change points")[0]
    assert a != b
    assert "moved at nightly-06" in b  # the first batch at the new level, read backwards


def test_scalar_lines_draw_the_level_where_a_line_moved() -> None:
    out = Output(fold(ScalarLines(), scrambled(_records())))
    data, level = out.lines("lat over time")
    assert level.x == data.x
    assert level.y_name == "lat over time (level)"
    assert level.y_unit == "ms"
    before = sum(data.y[:STEP]) / STEP
    after = sum(data.y[STEP:]) / (12 - STEP)
    assert level.y == pytest.approx([before] * STEP + [after] * (12 - STEP))
    assert level.statuses == ["PASSED"] * STEP + ["FAIL_WARN"] + ["PASSED"] * (11 - STEP)
    lv = out.by_name["lat over time"].raw.metric_values.line_plot_metric_values
    assert list(lv.legend_series_names) == ["lat", "level"]
    assert "Level moved at nightly-07 (2024-03-08): " in out.by_name["lat over time"].description
    assert len(out.lines("flat over time")) == 1  # did not move: one series

    off = Output(fold(ScalarLines(change_points=False), _records()))
    assert len(off.lines("lat over time")) == 1
    with pytest.raises(ValueError, match="change_penalty"):
        ScalarLines(change_penalty=-1.0)
