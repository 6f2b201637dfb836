"""ScalarLines: batch scalars over time, and the regression verdict of the latest batch.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle); see `support.Output`. Batches
are fed out of creation order on purpose: the aggregations sort by creation time
themselves.
"""

from __future__ import annotations

import math

import pytest

from stook.sdk import LinePlotMetric, MetricStatus
from stook.sdk.aggregations import Scalar
from stook.sdk.aggregations.report import ScalarLines, check
from tests.sdk.aggregations.report.support import Output, batch, days, fold, scrambled

# b0 has no batch metrics but is the report's first batch: the x axis starts there.
LINE_BATCHES = [
    batch(0, 0.0, jobs=[("e", "PASSED")]),
    batch(
        1,
        0.5,
        scalars={
            "lat": Scalar(10.0, "ms", "PASSED"),
            "dist": Scalar(100.0, "m"),
            "acc": Scalar(0.9),
        },
    ),
    batch(
        2,
        1.5,
        scalars={
            "lat": Scalar(10.5, "ms", "FAIL_WARN"),
            "dist": Scalar(101.0, "m"),
            "acc": Scalar(0.91),
        },
    ),
    batch(
        3,
        3.0,
        scalars={"lat": Scalar(9.5, "ms", "NOT_APPLICABLE"), "dist": Scalar(99.0, "m")},
    ),
    batch(
        4,
        4.5,
        scalars={"lat": Scalar(10.0, "s", "NO_STATUS_REPORTED"), "dist": Scalar(100.0, "m")},
    ),
    batch(
        5,
        6.5,
        scalars={
            "lat": Scalar(20.0, "ms", "FAIL_BLOCK"),
            "dist": Scalar(100.5, "m", "RAW"),
            "acc": Scalar(0.905, "", "SOMETHING_NEW"),
        },
    ),
]


def test_scalar_lines_values_by_creation_time_with_gaps() -> None:
    out = Output(fold(ScalarLines(), scrambled(LINE_BATCHES)))
    assert out.names == ["acc over time", "dist over time", "lat over time", "Regressions"]
    created = [r.created for r in LINE_BATCHES]

    lat = out.line("lat over time")
    assert lat.x == [0.5, 1.5, 3.0, 4.5, 6.5] == days(*created[1:])
    assert lat.y == [10.0, 10.5, 9.5, 10.0, 20.0]
    assert lat.times == created[1:]
    # API status strings; one the SDK cannot write reads as RAW
    assert lat.statuses == ["PASSED", "FAIL_WARN", "NOT_APPLICABLE", "RAW", "FAIL_BLOCK"]
    assert (lat.y_name, lat.y_unit) == ("lat over time", "ms")  # the most common unit

    acc = out.line("acc over time")  # b3 and b4 lack it: the line has a gap there
    assert acc.x == [0.5, 1.5, 6.5]
    assert acc.y == [0.9, 0.91, 0.905]
    assert acc.times == [created[1], created[2], created[5]]
    assert acc.statuses == ["PASSED", "PASSED", "RAW"]
    assert acc.y_unit == ""

    dist = out.line("dist over time")
    assert dist.y == [100.0, 101.0, 99.0, 100.0, 100.5]
    assert dist.statuses == ["PASSED"] * 4 + ["RAW"]

    lv = out.view.metric("lat over time", LinePlotMetric)
    assert lv.x_axis_name == "Days since 2024-03-01 12:00 UTC"
    assert lv.y_axis_name == "lat [ms]"
    assert lv.legend == ("lat",)
    av = out.view.metric("acc over time", LinePlotMetric)
    assert av.y_axis_name == "acc"
    assert av.x_axis_name == "Days since 2024-03-01 12:00 UTC"


def test_scalar_lines_status_is_fail_warn_exactly_when_regressed() -> None:
    agg = fold(ScalarLines(), scrambled(LINE_BATCHES))
    assert isinstance(agg, ScalarLines)
    verdicts = {m: v.regressed for m, (v, _) in agg.verdicts().items()}
    assert verdicts == {"acc": None, "dist": False, "lat": True}
    out = Output(agg)
    assert out.by_name["lat over time"].status is MetricStatus.FAIL_WARN
    assert out.by_name["dist over time"].status is MetricStatus.PASSED
    assert out.by_name["acc over time"].status is MetricStatus.PASSED
    assert out.writer.status is MetricStatus.FAIL_WARN


def test_scalar_lines_regressions_text_names_metric_values_and_batches() -> None:
    out = Output(fold(ScalarLines(), scrambled(LINE_BATCHES)))
    # lat: baseline 10, 10.5, 9.5, 10 -> median 10, MAD 0.25, scale 0.37065
    deviations = check([10.0, 10.5, 9.5, 10.0, 20.0], window=10, threshold=3.5).deviations
    assert f"{deviations:.1f}" == "27.0"
    lat_line = (
        "'lat' moved: 20 ms in b5 against a median of 10 ms (MAD 0.25) over 4 batches "
        "from b1 to b4: +10 ms (+100.0%), 27.0 robust deviations, since batch b4 (2024-03-06)."
    )
    text, status = out.text("Regressions")
    assert text == (
        "1 of 2 batch metrics moved in the latest batch (b5, 2024-03-08 00:00 UTC):\n- " + lat_line
    )
    assert status is MetricStatus.FAIL_WARN
    assert out.by_name["lat over time"].description == lat_line
    # dist: baseline 100, 101, 99, 100 -> median 100, MAD 0.5, the 2% floor (2) as scale
    assert out.by_name["dist over time"].description == (
        "'dist' is stable: 100.5 m in b5 against a median of 100 m (MAD 0.5) over 4 batches "
        "from b1 to b4: +0.5 m (+0.5%), 0.2 robust deviations, since batch b4 (2024-03-06)."
    )
    assert out.by_name["acc over time"].description == (
        "'acc': no regression verdict (2 earlier batches; at least 3 are needed)."
    )


def test_scalar_lines_no_regression_text() -> None:
    xs = [4.0, 6.0, 5.0, 7.0, 6.0]
    records = [batch(i, float(i), scalars={"x": x, "y": 1.0}) for i, x in enumerate(xs)]
    out = Output(fold(ScalarLines(window=3, threshold=2.5), scrambled(records)))
    text, status = out.text("Regressions")
    assert text == (
        "No regression: in the latest batch (b4) all 2 judged batch metrics are within 2.5 "
        "robust deviations of the median of up to 3 earlier batches."
    )
    assert status is MetricStatus.PASSED
    assert out.writer.status is MetricStatus.PASSED
    # window 3: the baseline is b1..b3 (6, 5, 7), not b0..b3
    assert out.by_name["x over time"].description == (
        "'x' is stable: 6 in b4 against a median of 6 (MAD 1) over 3 batches from b1 to b3: "
        "+0 (+0.0%), 0.0 robust deviations, since batch b3 (2024-03-04)."
    )
    assert out.by_name["x over time"].status is MetricStatus.PASSED
    assert out.line("x over time").y == xs


def test_scalar_lines_window_and_threshold_change_the_verdict() -> None:
    # x: 5, 6, 5, 6, 5; y flat. Window 3: baseline 6, 5, 6 -> median 6, MAD 0,
    # scale 0.12, 8.33 deviations: moved. Window 4: median 5.5, MAD 0.5, 0.674 deviations.
    records = [batch(i, float(i), scalars={"x": 5.0 + i % 2, "y": 1.0}) for i in range(5)]
    narrow = fold(ScalarLines(window=3, threshold=2.5), records)
    wide = fold(ScalarLines(window=4, threshold=2.5), records)
    assert isinstance(narrow, ScalarLines)
    assert isinstance(wide, ScalarLines)
    assert narrow.verdicts()["x"][0].regressed is True
    assert narrow.verdicts()["x"][0].deviations == pytest.approx(1.0 / 0.12)
    assert wide.verdicts()["x"][0].regressed is False
    assert wide.verdicts()["x"][0].deviations == pytest.approx(0.5 / (1.4826 * 0.5))
    text, status = Output(narrow).text("Regressions")
    assert text == (
        "1 of 2 batch metrics moved in the latest batch (b4, 2024-03-05 12:00 UTC):\n"
        "- 'x' moved: 5 in b4 against a median of 6 (MAD 0) over 3 batches from b1 to b3: "
        "-1 (-16.7%), 8.3 robust deviations, since batch b3 (2024-03-04)."
    )
    assert status is MetricStatus.FAIL_WARN
    text, status = Output(wide).text("Regressions")
    assert text.startswith("No regression: in the latest batch (b4) all 2 judged")
    assert "of up to 4 earlier batches." in text
    assert status is MetricStatus.PASSED


def test_scalar_lines_single_batch_gives_no_verdict() -> None:
    out = Output(fold(ScalarLines(), [batch(7, 2.0, scalars={"lat": Scalar(3.0, "ms")})]))
    text, status = out.text("Regressions")
    assert text == "Only one batch in the report (b7): no regression verdict."
    assert status is MetricStatus.NOT_APPLICABLE
    lat = out.line("lat over time")
    assert (lat.x, lat.y, lat.statuses) == ([0.0], [3.0], ["PASSED"])
    m = out.by_name["lat over time"]
    assert m.status is MetricStatus.PASSED
    assert (
        m.description == "'lat': no regression verdict (0 earlier batches; at least 3 are needed)."
    )
    assert out.view.metric(m.name, LinePlotMetric).x_axis_name == (
        "Days since 2024-03-03 12:00 UTC"
    )
    assert out.writer.status is MetricStatus.PASSED


def test_scalar_lines_single_batch_without_metrics_still_says_so() -> None:
    out = Output(fold(ScalarLines(name="Moves"), [batch(1, 0.0)]))
    assert out.names == ["Moves"]
    assert out.text("Moves") == (
        "Only one batch in the report (b1): no regression verdict.",
        MetricStatus.NOT_APPLICABLE,
    )


def test_scalar_lines_too_few_batches_for_any_verdict() -> None:
    records = [batch(i, float(i), scalars={"lat": 1.0 + i}) for i in range(3)]
    out = Output(fold(ScalarLines(), records))
    text, status = out.text("Regressions")
    assert text == (
        "No regression verdict: no batch metric has 3 or more earlier batches to compare "
        "the latest one with."
    )
    assert status is MetricStatus.NOT_APPLICABLE
    assert out.line("lat over time").y == [1.0, 2.0, 3.0]


def test_scalar_lines_without_batches_write_nothing() -> None:
    out = Output(ScalarLines())
    assert out.names == []


STALE_BATCHES = [batch(i, float(i), scalars={"old": 1.0}) for i in range(4)] + [
    batch(4, 4.0, scalars={"old": 9.0}),
    batch(5, 5.0, scalars={"new": 1.0}),
]


def test_scalar_lines_of_a_metric_missing_from_the_latest_batch() -> None:
    out = Output(fold(ScalarLines(), scrambled(STALE_BATCHES)))
    old = out.line("old over time")
    assert (old.x, old.y) == ([0.0, 1.0, 2.0, 3.0, 4.0], [1.0, 1.0, 1.0, 1.0, 9.0])
    new = out.line("new over time")
    assert (new.x, new.y) == ([5.0], [1.0])


def test_scalar_lines_do_not_say_a_stale_metric_moved_in_the_latest_batch() -> None:
    out = Output(fold(ScalarLines(), scrambled(STALE_BATCHES)))
    text, _ = out.text("Regressions")
    # 'old' has no value in the latest batch b5: no verdict on it, and no claim it moved.
    assert "'old' moved" not in text
    assert out.by_name["old over time"].status is MetricStatus.PASSED
    assert out.by_name["old over time"].description == (
        "'old': no regression verdict (the latest batch (b5) does not report it)."
    )


def test_scalar_lines_non_finite_latest_value_gives_no_verdict() -> None:
    records = [batch(i, float(i), scalars={"lat": v}) for i, v in enumerate([1.0] * 4 + [math.inf])]
    out = Output(fold(ScalarLines(), scrambled(records)))
    assert out.line("lat over time").y == [1.0, 1.0, 1.0, 1.0, math.inf]
    m = out.by_name["lat over time"]
    assert m.status is MetricStatus.PASSED
    assert m.description == (
        "'lat': no regression verdict (the latest value is not a finite number)."
    )
    assert out.text("Regressions")[1] is MetricStatus.NOT_APPLICABLE


# b1 is infinite: check() leaves it out, so the baseline of b5 is b0, b2, b3 and b4.
INFINITE_IN_BASELINE = [
    batch(i, float(i), scalars={"lat": v})
    for i, v in enumerate([10.0, math.inf, 10.0, 10.0, 10.0, 20.0])
]


def test_scalar_lines_leave_an_infinite_batch_out_of_the_baseline() -> None:
    agg = fold(ScalarLines(), scrambled(INFINITE_IN_BASELINE))
    assert isinstance(agg, ScalarLines)
    verdict, _ = agg.verdicts()["lat"]
    assert (verdict.regressed, verdict.baseline_size, verdict.baseline_median) == (True, 4, 10.0)
    out = Output(agg)
    assert out.line("lat over time").y == [10.0, math.inf, 10.0, 10.0, 10.0, 20.0]
    assert out.by_name["lat over time"].status is MetricStatus.FAIL_WARN


def test_scalar_lines_name_the_first_batch_of_a_baseline_with_an_infinite_value() -> None:
    out = Output(fold(ScalarLines(), scrambled(INFINITE_IN_BASELINE)))
    assert "over 4 batches from b0 to b4" in out.by_name["lat over time"].description


def test_scalar_lines_ties_in_creation_time_are_broken_by_batch_id() -> None:
    a = batch(1, 1.0, scalars={"x": 1.0})  # batch ID 999
    b = batch(2, 1.0, scalars={"x": 2.0})  # batch ID 998: first
    assert b.batch_id < a.batch_id
    for order in ([a, b], [b, a]):
        out = Output(fold(ScalarLines(), order))
        assert out.line("x over time").y == [2.0, 1.0]
        assert out.line("x over time").x == [0.0, 0.0]
        assert out.text("Regressions")[0].startswith("No regression verdict")


@pytest.mark.parametrize(("window", "threshold"), [(0, 3.5), (3, 0.0), (3, -1.0)])
def test_scalar_lines_refuse_bad_settings(window: int, threshold: float) -> None:
    with pytest.raises(ValueError, match="window must be at least 1 and threshold positive"):
        ScalarLines(window=window, threshold=threshold)
