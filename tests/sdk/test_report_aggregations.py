"""The report aggregations: exact values on small hand-made batches.

Every output is read back from the writer's bytes and validated twice: by stook's
validator and by ReSim's own (the platform's oracle). Batches are fed out of creation
order on purpose: the aggregations sort by creation time themselves.
"""

from __future__ import annotations

import dataclasses
import math
import statistics
import uuid
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from datetime import UTC, datetime, timedelta
from typing import Any

import pytest
import resim.metrics.proto.metrics_pb2 as rp
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.sdk import (
    JobMetricsView,
    MetricStatus,
    MetricsWriter,
    MetricType,
    MetricView,
    SeriesKind,
    read_job_metrics,
    validate_job_metrics,
)
from stook.sdk.aggregations import (
    BatchRecord,
    JobSummary,
    ReportAggregation,
    Scalar,
    build_all,
    default_report_aggregations,
)
from stook.sdk.aggregations.report import (
    BatchMetricStatusCounts,
    FlakyExperiences,
    JobMetricStatusCounts,
    JobScalarDistributions,
    MostFailedExperiences,
    ScalarLines,
    TestStatusOverTime,
    check,
)

REPORT_ID = uuid.UUID("0d0d0d0d-1111-4222-8333-444444444444")
PROJECT_ID = "5e5e5e5e-1111-4222-8333-444444444444"
T0 = datetime(2024, 3, 1, 12, 0, tzinfo=UTC)


# ---------------------------------------------------------------- helpers


def batch(
    n: int,
    days: float,
    *,
    name: str | None = None,
    scalars: Mapping[str, Scalar | float] | None = None,
    metric_statuses: Sequence[str] = (),
    jobs: Sequence[tuple[str, str]] = (),
    job_scalars: Mapping[str, Sequence[float]] | None = None,
    job_scalar_units: Mapping[str, str] | None = None,
    job_metric_statuses: Sequence[str] = (),
) -> BatchRecord:
    """Batch number `n`, created `days` after T0; jobs as (experience, conflated status)."""
    return BatchRecord(
        # IDs run against creation order, so that sorting by ID would be caught.
        batch_id=uuid.UUID(int=1000 - n),
        name=name if name is not None else f"b{n}",
        created=T0 + timedelta(days=days),
        scalars={
            k: v if isinstance(v, Scalar) else Scalar(float(v)) for k, v in (scalars or {}).items()
        },
        metric_statuses=tuple(metric_statuses),
        jobs=tuple(
            JobSummary(uuid.UUID(int=n * 1000 + i), experience, status)
            for i, (experience, status) in enumerate(jobs)
        ),
        job_scalars=dict(job_scalars or {}),
        job_scalar_units=dict(job_scalar_units or {}),
        job_metric_statuses=tuple(job_metric_statuses),
    )


def scrambled(records: Sequence[BatchRecord]) -> list[BatchRecord]:
    """Not in creation order: odd positions first, then even ones backwards."""
    return list(records[1::2]) + list(records[::2])[::-1]


def fold(aggregation: ReportAggregation, records: Iterable[BatchRecord]) -> ReportAggregation:
    for record in records:
        aggregation.update(record)
    return aggregation


@dataclass(frozen=True)
class Line:
    x: list[float]
    y: list[float]
    statuses: list[str]
    times: list[datetime]
    y_name: str
    y_unit: str


class Output:
    """What a set of finished aggregations wrote, read back and validated."""

    def __init__(self, *aggregations: ReportAggregation) -> None:
        self.writer = MetricsWriter(REPORT_ID, deterministic=True)
        for aggregation in aggregations:
            aggregation.finish(self.writer)
        raw = self.writer.serialize()
        validate_job_metrics(self.writer.to_proto())
        resim_validate(rp.JobMetrics.FromString(raw))
        self.view: JobMetricsView = read_job_metrics(raw)
        self.by_name = {m.name: m for m in self.view.metrics}

    @property
    def names(self) -> list[str]:
        return [m.name for m in self.view.metrics]

    def metric(self, name: str, kind: MetricType) -> MetricView:
        m = self.by_name[name]
        assert m.type is kind
        return m

    def text(self, name: str) -> tuple[str, MetricStatus | int | None]:
        m = self.metric(name, MetricType.TEXT)
        return m.raw.metric_values.text_metric_values.text, m.status

    def _data(self, data_id: Any) -> Any:
        return self.view.data_by_id[uuid.UUID(data_id.id.data)]

    def lines(self, name: str) -> list[Line]:
        lv = self.metric(name, MetricType.LINE_PLOT).raw.metric_values.line_plot_metric_values
        out = []
        for xid, yid, sid in zip(
            lv.x_doubles_data_id, lv.y_doubles_data_id, lv.statuses_data_id, strict=True
        ):
            x, y, s = self._data(xid), self._data(yid), self._data(sid)
            assert x.unit == "days"
            assert x.index_id is not None
            assert x.index_id == y.index_id == s.index_id
            times = self.view.data_by_id[x.index_id]
            assert times.kind is SeriesKind.TIMESTAMP
            out.append(
                Line(
                    x=x.series().to_list(),
                    y=y.series().to_list(),
                    statuses=[str(v) for v in s.series().to_list()],
                    times=times.series().to_list(),
                    y_name=y.name,
                    y_unit=y.unit,
                )
            )
        return out

    def line(self, name: str) -> Line:
        (only,) = self.lines(name)
        return only

    def bars(self, name: str) -> dict[str, float]:
        bv = self.metric(name, MetricType.BAR_CHART).raw.metric_values.bar_chart_metric_values
        assert len(bv.values_data_id) == 1
        values = self._data(bv.values_data_id[0])
        assert values.index_id is not None
        labels = self.view.data_by_id[values.index_id].series().to_list()
        return dict(zip(labels, values.series().to_list(), strict=True))


def days(*moments: datetime) -> list[float]:
    return [(m - T0).total_seconds() / 86_400 for m in moments]


# ---------------------------------------------------------------- ScalarLines

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

    lv = out.by_name["lat over time"].raw.metric_values.line_plot_metric_values
    assert lv.x_axis_name == "Days since 2024-03-01 12:00 UTC"
    assert lv.y_axis_name == "lat [ms]"
    assert list(lv.legend_series_names) == ["lat"]
    av = out.by_name["acc over time"].raw.metric_values.line_plot_metric_values
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
    assert m.raw.metric_values.line_plot_metric_values.x_axis_name == (
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


# ---------------------------------------------------------------- MostFailedExperiences

EXPERIENCE_BATCHES = [
    batch(0, 0.0, jobs=[("alpha", "BLOCKER"), ("beta", "PASSED"), ("gamma", "ERROR")]),
    batch(
        1,
        1.0,
        jobs=[("alpha", "ERROR"), ("beta", "WARNING"), ("gamma", "PASSED"), ("delta", "CANCELLED")],
    ),
    batch(
        2,
        2.0,
        jobs=[
            ("alpha", "PASSED"),
            ("beta", "BLOCKER"),
            ("gamma", "BLOCKER"),
            ("delta", "ERROR"),
            ("epsilon", "QUEUED"),
        ],
    ),
    batch(3, 3.0, jobs=[("gamma", "RUNNING"), ("alpha", "ERROR"), ("alpha", "ERROR")]),
]


def test_most_failed_experiences_ranks_failed_jobs_with_ties_by_name() -> None:
    # alpha 4 (twice in b3), gamma 2, beta 1, delta 1; epsilon never failed
    out = Output(fold(MostFailedExperiences(), scrambled(EXPERIENCE_BATCHES)))
    assert out.bars("Most failed experiences") == {
        "alpha": 4.0,
        "gamma": 2.0,
        "beta": 1.0,
        "delta": 1.0,
    }
    assert list(out.bars("Most failed experiences")) == ["alpha", "gamma", "beta", "delta"]
    m = out.by_name["Most failed experiences"]
    assert m.status is MetricStatus.FAIL_WARN
    assert m.description == (
        "Failed jobs (BLOCKER or ERROR) per experience over 4 batches; top 4 of 4 that failed."
    )
    bv = m.raw.metric_values.bar_chart_metric_values
    assert (bv.x_axis_name, bv.y_axis_name) == ("Experience", "Failed jobs")


def test_most_failed_experiences_keeps_the_top_n() -> None:
    out = Output(fold(MostFailedExperiences(name="Worst", top_n=3), EXPERIENCE_BATCHES))
    assert out.bars("Worst") == {"alpha": 4.0, "gamma": 2.0, "beta": 1.0}  # delta cut by name
    assert out.by_name["Worst"].description == (
        "Failed jobs (BLOCKER or ERROR) per experience over 4 batches; top 3 of 4 that failed."
    )
    out = Output(fold(MostFailedExperiences(top_n=1), EXPERIENCE_BATCHES))
    assert out.bars("Most failed experiences") == {"alpha": 4.0}


def test_most_failed_experiences_without_failures_says_so() -> None:
    records = [
        batch(0, 0.0, jobs=[("a", "PASSED"), ("b", "WARNING")]),
        batch(1, 1.0, jobs=[("a", "CANCELLED")]),
        batch(2, 2.0),
    ]
    out = Output(fold(MostFailedExperiences(), records))
    assert out.text("Most failed experiences") == (
        "No job failed (BLOCKER or ERROR) in the report's 3 batches.",
        MetricStatus.PASSED,
    )
    assert Output(MostFailedExperiences()).names == []


# ---------------------------------------------------------------- FlakyExperiences

# In creation order; "-" marks a batch where the experience has no outcome.
#   A: F P F P F           -> 4 flips
#   B: P - P F -           -> 1 flip (absent from b1, only CANCELLED in b4)
#   C: P P P P P           -> 0 flips
#   D: F F F P -           -> 1 flip (b1: one failed job among passing ones fails it;
#                                     b3: WARNING and PASSED pass it)
#   E: - - P - F           -> 1 flip (QUEUED; PASSED with RUNNING; no job in b3)
FLAKY_BATCHES = [
    batch(
        0,
        0.0,
        jobs=[("A", "ERROR"), ("B", "PASSED"), ("C", "PASSED"), ("D", "BLOCKER"), ("E", "QUEUED")],
    ),
    batch(
        1,
        1.0,
        jobs=[
            ("A", "PASSED"),
            ("C", "PASSED"),
            ("D", "PASSED"),
            ("D", "ERROR"),
            ("E", "PASSED"),
            ("E", "RUNNING"),
        ],
    ),
    batch(
        2,
        2.0,
        jobs=[("A", "BLOCKER"), ("B", "WARNING"), ("C", "PASSED"), ("D", "ERROR"), ("E", "PASSED")],
    ),
    batch(
        3,
        3.0,
        jobs=[
            ("A", "WARNING"),
            ("B", "BLOCKER"),
            ("C", "PASSED"),
            ("D", "WARNING"),
            ("D", "PASSED"),
        ],
    ),
    batch(
        4,
        4.0,
        jobs=[("A", "ERROR"), ("B", "CANCELLED"), ("C", "WARNING"), ("E", "BLOCKER")],
    ),
]


def test_flaky_experiences_counts_flips_between_consecutive_outcomes() -> None:
    agg = fold(FlakyExperiences(), scrambled(FLAKY_BATCHES))
    assert isinstance(agg, FlakyExperiences)
    assert agg.flips() == {"A": 4, "B": 1, "C": 0, "D": 1, "E": 1}
    out = Output(agg)
    bars = out.bars("Flaky experiences")
    assert list(bars.items()) == [("A", 4.0), ("B", 1.0), ("D", 1.0), ("E", 1.0)]
    m = out.by_name["Flaky experiences"]
    assert m.status is MetricStatus.FAIL_WARN
    assert m.description == (
        "Times each experience's outcome changed between consecutive batches "
        "(failed: any job BLOCKER or ERROR; passed: all jobs PASSED or WARNING)."
    )
    bv = m.raw.metric_values.bar_chart_metric_values
    assert (bv.x_axis_name, bv.y_axis_name) == ("Experience", "Pass/fail flips")


def test_flaky_experiences_keeps_the_top_n() -> None:
    out = Output(fold(FlakyExperiences(name="Flaky", top_n=2), FLAKY_BATCHES))
    assert out.bars("Flaky") == {"A": 4.0, "B": 1.0}


def test_flaky_experiences_orders_by_creation_time_not_arrival_or_id() -> None:
    # By creation P F P: 2 flips. By arrival [b1, b0, b2] or by batch ID (b1 < b0 < b2
    # here) the outcomes would read F P P: 1 flip.
    records = [
        dataclasses.replace(batch(0, 0.0, jobs=[("x", "PASSED")]), batch_id=uuid.UUID(int=2)),
        dataclasses.replace(batch(1, 1.0, jobs=[("x", "ERROR")]), batch_id=uuid.UUID(int=1)),
        dataclasses.replace(batch(2, 2.0, jobs=[("x", "PASSED")]), batch_id=uuid.UUID(int=3)),
    ]
    for order in (records, [records[1], records[0], records[2]], records[::-1]):
        agg = fold(FlakyExperiences(), order)
        assert isinstance(agg, FlakyExperiences)
        assert agg.flips() == {"x": 2}


def test_flaky_experiences_without_flips_says_so() -> None:
    records = [batch(i, float(i), jobs=[("x", "PASSED"), ("y", "ERROR")]) for i in range(3)]
    out = Output(fold(FlakyExperiences(), records))
    assert out.text("Flaky experiences") == (
        "No experience flipped between passing and failing across consecutive batches.",
        MetricStatus.PASSED,
    )


def test_flaky_experiences_cancelled_only_batches_give_no_outcome() -> None:
    records = [batch(i, float(i), jobs=[("x", "CANCELLED")]) for i in range(3)]
    agg = fold(FlakyExperiences(), records)
    assert isinstance(agg, FlakyExperiences)
    assert agg.outcomes == {}
    assert Output(agg).names == []
    # Cancelled batches between a pass and a fail do not hide the flip.
    records += [batch(5, 5.0, jobs=[("x", "PASSED")]), batch(6, 6.0, jobs=[("x", "ERROR")])]
    agg = fold(FlakyExperiences(), scrambled(records))
    assert isinstance(agg, FlakyExperiences)
    assert agg.flips() == {"x": 1}


# ---------------------------------------------------------------- TestStatusOverTime


def test_status_over_time_counts_jobs_per_status_per_batch() -> None:
    records = [
        batch(0, 0.0, jobs=[("a", "PASSED"), ("b", "PASSED"), ("c", "BLOCKER")]),
        batch(1, 0.25),  # no jobs: zeros everywhere
        batch(
            2,
            2.0,
            jobs=[("a", "PASSED"), ("b", "ERROR"), ("c", "ODD"), ("d", "CANCELLED")],
        ),
    ]
    out = Output(fold(TestStatusOverTime(project_id=PROJECT_ID), scrambled(records)))
    m = out.metric("Test status over time", MetricType.BATCHWISE_BAR_CHART)
    bv = m.raw.metric_values.batchwise_bar_chart_metric_values
    # PASSED always; others only when seen, in the app's order; unknown ones after, by name
    assert list(bv.categories) == ["PASSED", "BLOCKER", "ERROR", "CANCELLED", "ODD"]
    assert list(bv.colors) == ["#2e7d32", "#c62828", "#6a1b9a", "#757575", "#9e9e9e"]
    assert bv.project_id.data == PROJECT_ID
    assert (bv.x_axis_name, bv.y_axis_name, bv.stack_bars) == ("Batch", "Jobs", True)
    expected = {
        "PASSED": [2.0, 0.0, 1.0],
        "BLOCKER": [1.0, 0.0, 0.0],
        "ERROR": [0.0, 0.0, 1.0],
        "CANCELLED": [0.0, 0.0, 1.0],
        "ODD": [0.0, 0.0, 1.0],
    }
    ids = [str(r.batch_id) for r in records]
    for category, tid, vid in zip(bv.categories, bv.times_data_id, bv.values_data_id, strict=True):
        times = out.view.data_by_id[uuid.UUID(tid.id.data)]
        values = out.view.data_by_id[uuid.UUID(vid.id.data)]
        assert values.name == f"Test status over time: {category}"
        assert values.series().to_list() == expected[category]
        assert times.series().to_list() == [r.created for r in records]
        assert values.index_id is not None
        assert values.index_id == times.index_id
        assert out.view.data_by_id[values.index_id].series().to_list() == ids
    assert m.status is MetricStatus.PASSED
    assert m.description == "Jobs per conflated status in each of 3 batches."


def test_status_over_time_of_batches_without_jobs_shows_passed_zeros() -> None:
    out = Output(
        fold(TestStatusOverTime(project_id=PROJECT_ID, name="S"), [batch(0, 0.0), batch(1, 1.0)])
    )
    bv = out.by_name["S"].raw.metric_values.batchwise_bar_chart_metric_values
    assert list(bv.categories) == ["PASSED"]
    values = out.view.data_by_id[uuid.UUID(bv.values_data_id[0].id.data)]
    assert values.series().to_list() == [0.0, 0.0]
    assert Output(TestStatusOverTime(project_id=PROJECT_ID)).names == []


# ---------------------------------------------------------------- status counts


def test_job_metric_status_counts_across_batches() -> None:
    records = [
        batch(0, 0.0, job_metric_statuses=["PASSED"] * 3 + ["FAIL_WARN", "RAW"]),
        batch(1, 1.0, job_metric_statuses=["NO_STATUS_REPORTED", "PASSED", "ODD"]),
        batch(2, 2.0),
    ]
    agg = JobMetricStatusCounts()
    assert agg.needs().job_metrics is True
    out = Output(fold(agg, scrambled(records)))
    bars = out.bars("Job metric statuses")
    assert list(bars.items()) == [
        ("PASSED", 4.0),
        ("FAIL_WARN", 1.0),
        ("FAIL_BLOCK", 0.0),
        ("RAW", 1.0),
        ("NO_STATUS_REPORTED", 1.0),
        ("ODD", 1.0),
    ]
    m = out.by_name["Job metric statuses"]
    assert m.status is MetricStatus.FAIL_WARN
    assert m.description == "8 job metrics by status."
    bv = m.raw.metric_values.bar_chart_metric_values
    assert (bv.x_axis_name, bv.y_axis_name) == ("Metric status", "Job metrics")


def test_batch_metric_status_counts_across_batches() -> None:
    records = [
        batch(0, 0.0, metric_statuses=["PASSED", "FAIL_BLOCK"]),
        batch(1, 1.0, metric_statuses=["NOT_APPLICABLE", "FAIL_WARN", "PASSED"]),
    ]
    agg = BatchMetricStatusCounts()
    assert agg.needs().job_metrics is False
    out = Output(fold(agg, records))
    assert out.bars("Batch metric statuses") == {
        "PASSED": 2.0,
        "FAIL_WARN": 1.0,
        "FAIL_BLOCK": 1.0,
        "NOT_APPLICABLE": 1.0,
    }
    m = out.by_name["Batch metric statuses"]
    assert m.status is MetricStatus.FAIL_BLOCK
    assert m.description == "5 batch metrics by status."
    assert m.raw.metric_values.bar_chart_metric_values.y_axis_name == "Batch metrics"


def test_status_counts_all_passed_and_empty() -> None:
    out = Output(fold(BatchMetricStatusCounts(), [batch(0, 0.0, metric_statuses=["PASSED"])]))
    assert out.bars("Batch metric statuses") == {
        "PASSED": 1.0,
        "FAIL_WARN": 0.0,
        "FAIL_BLOCK": 0.0,
    }
    assert out.by_name["Batch metric statuses"].status is MetricStatus.PASSED
    assert Output(fold(JobMetricStatusCounts(), [batch(0, 0.0)])).names == []
    assert Output(fold(BatchMetricStatusCounts(), [batch(0, 0.0)])).names == []


# ---------------------------------------------------------------- JobScalarDistributions


def expected_quantiles(values: Sequence[float]) -> list[float]:
    """p10, median, p90 by linear interpolation (statistics' 'inclusive' method)."""
    finite = sorted(v for v in values if math.isfinite(v))
    if len(finite) == 1:
        return finite * 3
    deciles = statistics.quantiles(finite, n=10, method="inclusive")
    return [deciles[0], statistics.median(finite), deciles[8]]


SPEED_0 = [3.0, 1.0, 2.0, 10.0, math.nan, 7.5, -4.0]
SPEED_2 = [4.0, -0.0, 0.0, 8.0, math.inf]

DISTRIBUTION_BATCHES = [
    batch(0, 0.0),  # the report's first batch, without job metrics: the axis starts here
    batch(
        1,
        1.0,
        job_scalars={"speed": SPEED_0, "dist": [5.0]},
        job_scalar_units={"speed": "m/s", "dist": "m"},
    ),
    batch(2, 2.0, job_scalars={"speed": [math.inf, -math.inf, math.nan]}),  # no finite value
    batch(3, 3.5, job_scalars={"speed": SPEED_2}, job_scalar_units={"speed": "m/s"}),
    batch(4, 4.0, job_scalars={"dist": []}),
]


def test_job_scalar_distributions_quantiles_per_batch() -> None:
    out = Output(fold(JobScalarDistributions(), scrambled(DISTRIBUTION_BATCHES)))
    assert out.names == ["dist per batch", "speed per batch"]
    p10, median, p90 = out.lines("speed per batch")
    assert p10.x == median.x == p90.x == [1.0, 3.5]  # b2 has no finite value: a gap
    assert p10.times == [T0 + timedelta(days=1), T0 + timedelta(days=3.5)]
    rows = [expected_quantiles(SPEED_0), expected_quantiles(SPEED_2)]
    # sorted finite: -4, 1, 2, 3, 7.5, 10 -> p10 at 0.5: -1.5; median 2.5; p90 at 4.5: 8.75
    assert rows[0] == [-1.5, 2.5, 8.75]
    # sorted finite: 0, 0, 4, 8 -> p10 at 0.3: 0; median 2; p90 at 2.7: 6.8
    assert rows[1] == pytest.approx([0.0, 2.0, 6.8])
    for i, line in enumerate((p10, median, p90)):
        assert line.y == pytest.approx([rows[0][i], rows[1][i]], rel=1e-12)
        assert line.statuses == ["PASSED", "PASSED"]
        assert line.y_unit == "m/s"
    assert math.copysign(1.0, p10.y[1]) == 1.0  # -0.0 is written as 0.0
    assert [p10.y_name, median.y_name, p90.y_name] == [
        "speed per batch (p10)",
        "speed per batch (median)",
        "speed per batch (p90)",
    ]
    m = out.by_name["speed per batch"]
    lv = m.raw.metric_values.line_plot_metric_values
    assert list(lv.legend_series_names) == ["p10", "median", "p90"]
    assert lv.x_axis_name == "Days since 2024-03-01 12:00 UTC"
    assert lv.y_axis_name == "speed [m/s]"
    assert m.status is MetricStatus.PASSED
    assert m.description == (
        "10th percentile, median and 90th percentile of 'speed' across each batch's jobs "
        "(10 job values in 2 batches)."
    )

    dist = out.lines("dist per batch")
    assert [line.y for line in dist] == [[5.0], [5.0], [5.0]]
    assert dist[0].x == [1.0]
    assert out.by_name["dist per batch"].raw.metric_values.line_plot_metric_values.y_axis_name == (
        "dist [m]"
    )


def test_job_scalar_distributions_against_interpolation_on_more_values() -> None:
    values = [((i * 7919) % 1009) / 13.0 - 20.0 for i in range(97)]
    records = [
        batch(i, float(i), job_scalars={"v": values[i * 10 : i * 10 + 10 + i]}) for i in range(8)
    ]
    out = Output(fold(JobScalarDistributions(), scrambled(records)))
    lines = out.lines("v per batch")
    for q, line in enumerate(lines):
        assert line.x == [float(i) for i in range(8)]
        assert line.y == pytest.approx(
            [expected_quantiles(r.job_scalars["v"])[q] for r in records], rel=1e-12
        )


def test_job_scalar_distributions_only_the_metrics_asked_for() -> None:
    agg = JobScalarDistributions(metrics=["dist"])
    assert agg.needs().job_metrics is True
    assert agg.needs().scalars == {"dist"}
    out = Output(fold(agg, DISTRIBUTION_BATCHES))
    assert out.names == ["dist per batch"]
    assert Output(fold(JobScalarDistributions(metrics=[]), DISTRIBUTION_BATCHES)).names == []
    assert Output(fold(JobScalarDistributions(), [batch(0, 0.0)])).names == []


# ---------------------------------------------------------------- defaults and config


def test_default_report_aggregations_write_valid_metrics_together() -> None:
    records = [
        batch(
            i,
            float(i),
            scalars={"lat": Scalar(10.0 + (i == 5) * 50, "ms")},
            metric_statuses=["PASSED"],
            jobs=[("a", "PASSED"), ("b", "ERROR" if i % 2 else "PASSED")],
            job_scalars={"speed": [1.0, 2.0 + i]},
            job_metric_statuses=["PASSED", "FAIL_WARN"],
        )
        for i in range(6)
    ]
    aggregations = default_report_aggregations(project_id=PROJECT_ID, top_n=5)
    for aggregation in aggregations:
        fold(aggregation, scrambled(records))
    out = Output(*aggregations)
    assert out.names == [
        "lat over time",
        "Regressions",
        "Most failed experiences",
        "Test status over time",
        "Job metric statuses",
        "Batch metric statuses",
        "speed per batch",
        "Flaky experiences",
    ]
    assert out.bars("Most failed experiences") == {"b": 3.0}
    assert out.bars("Flaky experiences") == {"b": 5.0}
    assert out.by_name["lat over time"].status is MetricStatus.FAIL_WARN
    assert out.writer.status is MetricStatus.FAIL_WARN


def test_default_report_aggregations_take_the_report_settings() -> None:
    aggregations = default_report_aggregations(
        project_id=PROJECT_ID,
        top_n=3,
        regression_window=4,
        regression_threshold=2.0,
        job_metrics=["speed"],
    )
    lines, most, status, _, _, dist, flaky = aggregations
    assert isinstance(lines, ScalarLines)
    assert (lines.window, lines.threshold) == (4, 2.0)
    assert isinstance(most, MostFailedExperiences)
    assert most.top_n == 3
    assert isinstance(status, TestStatusOverTime)
    assert status.project_id == PROJECT_ID
    assert isinstance(dist, JobScalarDistributions)
    assert dist.metrics == ["speed"]
    assert isinstance(flaky, FlakyExperiences)
    assert flaky.top_n == 3


def test_report_section_builds_report_kinds() -> None:
    built = build_all(
        {
            "scalar_lines": [{"window": 3, "threshold": 2.0, "name": "R"}],
            "most_failed_experiences": [{"top_n": 2}],
            "test_status_over_time": [{"project_id": PROJECT_ID}],
        },
        section="report",
    )
    lines, most, status = built
    assert isinstance(lines, ScalarLines)
    assert (lines.window, lines.threshold) == (3, 2.0)
    assert isinstance(most, MostFailedExperiences)
    assert most.top_n == 2
    assert isinstance(status, TestStatusOverTime)
    records = [batch(i, float(i), scalars={"x": 1.0}) for i in range(5)]
    assert Output(fold(lines, records)).text("R")[0].endswith("of up to 3 earlier batches.")
