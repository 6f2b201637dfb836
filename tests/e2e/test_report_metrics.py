"""Report mode end to end: `stook run` on an emulated report, every default metric against
an independent computation from the emulator's ground truth, and the [report] settings.

The helpers here (running report mode, reading report charts back, the expected report)
are shared by the other test_report_*.py files.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import json
import os
import statistics
from collections import Counter
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path

import pytest

from stook.emulator import BatchSpec, Emulator
from stook.sdk import (
    BatchwiseBarChartMetric,
    JobMetricsView,
    LinePlotMetric,
    MetricStatus,
    MetricView,
)
from stook.service.cli import run_cli
from tests.e2e.support import (
    OUTPUT_NAME,
    UNITS,
    EmulatorThread,
    bar_chart,
    by_name,
    config,
    outputs_left,
    quantile,
    read_output,
    text_of,
    worst,
)
from tests.failures import failure_lines

SEED = 17
BATCHES = 13
JOBS = 30
FAILED = {"BLOCKER", "ERROR"}
PASSED = {"PASSED", "WARNING"}
# The app's order of conflated job statuses (PASSED is always shown).
JOB_STATUS_ORDER = ("PASSED", "WARNING", "BLOCKER", "ERROR", "CANCELLED", "QUEUED", "RUNNING")
# The regression rule as documented: robust deviations 1.4826 x MAD, floored at 2% of the
# baseline median; fewer than 3 earlier batches give no verdict.
MAD_SIGMA, FLOOR, MIN_BASELINE = 1.4826, 0.02, 3


# ---- running report mode ----


@dataclass(frozen=True)
class Run:
    code: int
    out: str
    err: str
    outputs: Path

    @property
    def output(self) -> Path:
        return self.outputs / OUTPUT_NAME

    def view(self) -> JobMetricsView:
        assert self.code == 0, self.err
        return read_output(self.output)  # validated by ReSim's own validator first


@contextlib.contextmanager
def clean_environment() -> Iterator[None]:
    """No STOOK_* settings from the environment (module fixtures cannot use monkeypatch)."""
    with pytest.MonkeyPatch.context() as mp:
        for name in list(os.environ):
            if name.startswith("STOOK_"):
                mp.delenv(name)
        yield


def run_report_cli(
    emu: Emulator, tmp: Path, toml: str = "", *extra: str, report_id: str | None = None
) -> Run:
    """`stook run` on the emulator's report (or `report_id`), with an explicit (maybe
    empty) stook.toml; stdout and stderr captured."""
    inputs, outputs = tmp / "inputs", tmp / "outputs"
    path = emu.write_report_config(inputs)
    if report_id is not None:
        path.write_text(json.dumps({**json.loads(path.read_text()), "reportID": report_id}))
    config_file = tmp / "stook.toml"
    config_file.write_text(toml)
    argv = ["run", "--inputs", str(inputs), "--outputs", str(outputs)]
    argv += ["--config", str(config_file), "--log-level", "warning", *extra]
    out, err = io.StringIO(), io.StringIO()
    with clean_environment(), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = run_cli(argv)
    return Run(code, out.getvalue(), err.getvalue(), outputs)


# ---- reading report charts back ----


@dataclass(frozen=True)
class Line:
    x: list[float]
    y: list[float]
    statuses: list[str]
    times: list[datetime]
    unit: str


def lines(view: JobMetricsView, metric: MetricView) -> list[Line]:
    plot = view.metric(metric.name, LinePlotMetric)
    out = []
    for x, y, statuses in zip(
        plot.x_doubles_data, plot.y_doubles_data, plot.statuses_data, strict=True
    ):
        assert x.index is not None
        assert y.index_id == x.index_id
        times = x.index.series().to_list()
        out.append(
            Line(
                x.series().to_list(),
                y.series().to_list(),
                [str(s) for s in statuses.series().to_list()],
                times,
                y.unit,
            )
        )
    return out


def the_line(view: JobMetricsView, metric: MetricView) -> Line:
    """The data series of an `N over time` line (a second one, the level, may follow)."""
    line, *level = lines(view, metric)
    assert len(level) <= 1
    return line


@dataclass(frozen=True)
class Batchwise:
    categories: list[str]
    batch_ids: dict[str, list[str]]
    times: dict[str, list[datetime]]
    values: dict[str, list[float]]


def batchwise(view: JobMetricsView, metric: MetricView) -> Batchwise:
    chart = view.metric(metric.name, BatchwiseBarChartMetric)
    categories = list(chart.categories)
    ids, times, values = {}, {}, {}
    pairs = zip(chart.times_data, chart.values_data, strict=True)
    for category, (t, v) in zip(categories, pairs, strict=True):
        assert v.index is not None
        assert t.index_id == v.index_id
        ids[category] = [str(i) for i in v.index.series().to_list()]
        times[category] = t.series().to_list()
        values[category] = v.series().to_list()
    return Batchwise(categories, ids, times, values)


def status_name(metric: MetricView) -> str:
    assert isinstance(metric.status, MetricStatus)
    return metric.status.name


# ---- the expected report, from the emulator's ground truth alone ----


def days(origin: datetime, moment: datetime) -> float:
    return (moment - origin).total_seconds() / 86_400


def verdict(values: Sequence[float], window: int, threshold: float) -> bool | None:
    """Whether the last value regressed against up to `window` values before it."""
    baseline = list(values[:-1])[-window:]
    if len(baseline) < MIN_BASELINE:
        return None
    median = statistics.median(baseline)
    mad = statistics.median(abs(v - median) for v in baseline)
    scale = max(MAD_SIGMA * mad, FLOOR * abs(median), 1e-12)
    deviations = abs(values[-1] - median) / scale
    assert abs(deviations - threshold) > 1e-6, "too close to the threshold to judge"
    return deviations > threshold


@dataclass(frozen=True)
class Point:
    batch: BatchSpec
    x: float
    y: float
    status: str


@dataclass(frozen=True)
class ExpectedReport:
    batches: list[BatchSpec]
    jobs: int
    scalar_lines: dict[str, list[Point]]
    scalar_units: dict[str, str]
    verdicts: dict[str, bool | None]
    most_failed: list[tuple[str, float]]
    status_counts: dict[str, list[float]]  # category -> count per batch
    job_metric_statuses: Counter[str]
    batch_metric_statuses: Counter[str]
    per_batch: dict[str, list[tuple[float, float, float, float]]]  # (x, p10, p50, p90)
    flips: list[tuple[str, float]]

    @property
    def origin(self) -> datetime:
        return self.batches[0].created

    def names(self) -> set[str]:
        if not self.batches:
            return {"Report summary"}
        names = {"Report summary", "Regressions", "Most failed experiences"}
        names |= {"Test status over time", "Flaky experiences"}
        names |= {"Change points", "Unstable experiences"}
        names |= {f"{n} over time" for n in self.scalar_lines}
        names |= {f"{n} per batch" for n in self.per_batch}
        if self.job_metric_statuses:
            names.add("Job metric statuses")
        if self.batch_metric_statuses:
            names.add("Batch metric statuses")
        return names


def expected_report(
    emu: Emulator,
    *,
    top_n: int = 10,
    window: int = 10,
    threshold: float = 3.5,
    job_metrics: Sequence[str] | None = None,
) -> ExpectedReport:
    ds = emu.dataset
    batches = ds.report_batches()
    origin = batches[0].created if batches else None

    scalar_lines: dict[str, list[Point]] = {}
    units: dict[str, Counter[str]] = {}
    for batch, scalars in ds.report_batch_scalars():
        assert origin is not None
        for name, (value, unit, status) in scalars.items():
            scalar_lines.setdefault(name, []).append(
                Point(batch, days(origin, batch.created), value, status)
            )
            units.setdefault(name, Counter())[unit] += 1
    # A series is judged on the report's latest batch only: without it, no verdict.
    verdicts = {
        name: verdict([p.y for p in points], window, threshold)
        if points[-1].batch == batches[-1]
        else None
        for name, points in scalar_lines.items()
    }

    failures: Counter[str] = Counter()
    outcomes: dict[str, list[bool]] = {}
    for _, per_experience in ds.report_job_statuses():
        for experience, statuses in sorted(per_experience.items()):
            failures[experience] += sum(s in FAILED for s in statuses)
            if any(s in FAILED for s in statuses):
                outcomes.setdefault(experience, []).append(True)
            elif all(s in PASSED for s in statuses):
                outcomes.setdefault(experience, []).append(False)
    flip_counts = {
        e: sum(a != b for a, b in itertools.pairwise(seq)) for e, seq in outcomes.items()
    }

    per_batch_status = [Counter(j.conflated_status for j in ds.jobs(b.id)) for b in batches]
    seen = Counter[str]()
    for counts in per_batch_status:
        seen.update(counts)
    categories = [s for s in JOB_STATUS_ORDER if s == "PASSED" or seen[s]]
    categories += sorted(s for s in seen if s not in JOB_STATUS_ORDER)

    job_metric_statuses: Counter[str] = Counter()
    per_batch: dict[str, list[tuple[float, float, float, float]]] = {}
    jobs = 0
    for batch in batches:
        assert origin is not None
        jobs += len(ds.jobs(batch.id))
        for statuses_by_job in ds.metric_statuses(batch.id).values():
            job_metric_statuses.update(statuses_by_job.values())
        for name, values_by_job in sorted(ds.scalar_values(batch.id).items()):
            if job_metrics is not None and name not in job_metrics:
                continue
            values = list(values_by_job.values())
            per_batch.setdefault(name, []).append(
                (
                    days(origin, batch.created),
                    quantile(values, 0.10),
                    quantile(values, 0.50),
                    quantile(values, 0.90),
                )
            )
    batch_metric_statuses: Counter[str] = Counter()
    for _, by_metric in ds.report_batch_metric_statuses():
        batch_metric_statuses.update(by_metric.values())

    return ExpectedReport(
        batches=batches,
        jobs=jobs,
        scalar_lines=scalar_lines,
        scalar_units={n: u.most_common(1)[0][0] for n, u in units.items()},
        verdicts=verdicts,
        most_failed=ranked(failures, top_n),
        status_counts={s: [float(counts[s]) for counts in per_batch_status] for s in categories},
        job_metric_statuses=job_metric_statuses,
        batch_metric_statuses=batch_metric_statuses,
        per_batch=per_batch,
        flips=ranked(Counter(flip_counts), top_n),
    )


def ranked(counts: Counter[str], top_n: int) -> list[tuple[str, float]]:
    """Most first, ties by name, zeros left out."""
    order = sorted((name for name, n in counts.items() if n > 0), key=lambda e: (-counts[e], e))
    return [(name, float(counts[name])) for name in order[:top_n]]


def assert_report_matches(view: JobMetricsView, expected: ExpectedReport) -> None:
    """Every default report metric against the expected report."""
    metrics = by_name(view)
    # Written when there is something to say (test_report_change_points.py says what).
    optional = {"Failure rate over time", "Unstable experiences (details)"}
    assert expected.names() <= set(metrics) <= expected.names() | optional
    if not expected.batches:
        return

    # N over time: one point per batch that has N, x in days since the first batch; a
    # second series, the level, where the line moved (test_report_change_points.py).
    for name, points in expected.scalar_lines.items():
        metric = metrics[f"{name} over time"]
        line, *level = lines(view, metric)
        assert len(level) <= 1, name
        if level:
            assert level[0].x == line.x, name
        assert line.x == pytest.approx([p.x for p in points], rel=1e-12, abs=1e-12), name
        assert line.y == [p.y for p in points], name
        assert line.statuses == [p.status for p in points], name
        assert line.times == [p.batch.created for p in points], name
        assert line.unit == expected.scalar_units[name], name
        wanted = "FAIL_WARN" if expected.verdicts[name] else "PASSED"
        assert status_name(metric) == wanted, name
        axis = view.metric(metric.name, LinePlotMetric).x_axis_name
        assert axis == f"Days since {expected.origin:%Y-%m-%d %H:%M} UTC"

    # Regressions: which series moved.
    regressions = metrics["Regressions"]
    text = text_of(regressions)
    moved = sorted(n for n, v in expected.verdicts.items() if v)
    judged = sum(v is not None for v in expected.verdicts.values())
    latest = expected.batches[-1]
    for name in expected.scalar_lines:
        assert (f"{name!r} moved" in text) == (name in moved), (name, text)
    if len(expected.batches) == 1:
        assert (
            text == f"Only one batch in the report ({latest.friendly_name}): no regression verdict."
        )
        assert status_name(regressions) == "NOT_APPLICABLE"
    elif moved:
        assert text.startswith(f"{len(moved)} of {judged} batch metrics moved in the latest batch")
        assert latest.friendly_name in text
        assert status_name(regressions) == "FAIL_WARN"
    elif judged == 0:
        assert text.startswith("No regression verdict"), text
        assert status_name(regressions) == "NOT_APPLICABLE"
    else:
        assert text.startswith("No regression:"), text
        assert f"all {judged} judged batch metrics" in text
        assert status_name(regressions) == "PASSED"

    # Most failed experiences (BLOCKER or ERROR jobs), most first, top N.
    most_failed = metrics["Most failed experiences"]
    assert list(bar_chart(view, most_failed).items()) == expected.most_failed
    assert status_name(most_failed) == "FAIL_WARN"

    # Test status over time: per status, per batch job counts.
    chart = batchwise(view, metrics["Test status over time"])
    assert chart.categories == list(expected.status_counts)
    for category, counts in expected.status_counts.items():
        assert chart.values[category] == counts, category
        assert chart.batch_ids[category] == [str(b.id) for b in expected.batches]
        assert chart.times[category] == [b.created for b in expected.batches]
    totals = [sum(c) for c in zip(*expected.status_counts.values(), strict=True)]
    assert totals == [float(b.job_count) for b in expected.batches]

    # Status counts of every job metric and every batch metric.
    for name, status_counts in (
        ("Job metric statuses", expected.job_metric_statuses),
        ("Batch metric statuses", expected.batch_metric_statuses),
    ):
        if not status_counts:
            continue
        got = bar_chart(view, metrics[name])
        nonzero = {k: float(n) for k, n in status_counts.items()}
        assert {k: v for k, v in got.items() if v} == nonzero, name
        assert {"PASSED", "FAIL_WARN", "FAIL_BLOCK"} <= set(got), name
        wanted_status = worst(k for k, n in status_counts.items() if n)
        assert status_name(metrics[name]) == wanted_status, name

    # N per batch: p10, median and p90 of each SCALAR job metric across each batch's jobs.
    for name, rows in expected.per_batch.items():
        metric = metrics[f"{name} per batch"]
        got_lines = lines(view, metric)
        assert len(got_lines) == 3
        legend = view.metric(metric.name, LinePlotMetric).legend
        assert legend == ("p10", "median", "p90")
        for i, line in enumerate(got_lines, start=1):
            assert line.x == pytest.approx([r[0] for r in rows], rel=1e-12, abs=1e-12), name
            assert line.y == pytest.approx([r[i] for r in rows], rel=1e-12, abs=1e-15), name
            assert line.unit == UNITS[name], name
            assert set(line.statuses) == {"PASSED"}

    # Flaky experiences: pass/fail flips between consecutive batches.
    flaky = metrics["Flaky experiences"]
    if expected.flips:
        assert list(bar_chart(view, flaky).items()) == expected.flips
    else:
        assert "No experience flipped" in text_of(flaky)

    # Report summary: batches and jobs.
    summary = text_of(metrics["Report summary"])
    first, last = expected.batches[0].created, expected.batches[-1].created
    assert summary.startswith(f"{len(expected.batches)} batches of test suite "), summary
    assert f": {expected.jobs} jobs, " in summary
    assert f"the first batch created {first:%Y-%m-%d %H:%M}" in summary
    assert f"the last {last:%Y-%m-%d %H:%M} UTC" in summary

    # The overall status follows the metrics' statuses.
    assert isinstance(view.status, MetricStatus)
    assert view.status.name == worst(status_name(m) for m in view.metrics)


# ---- the tests ----


@pytest.fixture(scope="module")
def emu() -> Iterator[Emulator]:
    with EmulatorThread(
        config(seed=SEED, report_batches=BATCHES, report_jobs_per_batch=JOBS)
    ) as emulator:
        yield emulator


@pytest.fixture(scope="module")
def quirky_emu() -> Iterator[Emulator]:
    """The same report, answered the way the spec allows (see EmulatorConfig.spec_quirks)."""
    with EmulatorThread(
        config(seed=SEED, report_batches=BATCHES, report_jobs_per_batch=JOBS, spec_quirks=True)
    ) as emulator:
        yield emulator


# With the spec's quirks the output is byte-identical to the clean one
# (test_spec_answers.py, quick); comparing it with the truth again is the slow tier's.
@pytest.mark.parametrize(
    "emulator",
    ["emu", pytest.param("quirky_emu", marks=pytest.mark.slow)],
    ids=["clean", "spec-quirks"],
)
def test_every_default_metric_matches_the_ground_truth(
    emulator: str, request: pytest.FixtureRequest, tmp_path: Path
) -> None:
    emu: Emulator = request.getfixturevalue(emulator)
    run = run_report_cli(emu, tmp_path)
    view = run.view()
    expected = expected_report(emu)
    # The data set shows every case the metrics are about.
    assert len(expected.batches) == BATCHES
    assert {"Mean localization error", "Mean distance driven", "Pass rate"} <= set(
        expected.scalar_lines
    )
    assert len(expected.most_failed) == 10
    assert len(expected.flips) > 3
    assert {"PASSED", "WARNING", "BLOCKER", "ERROR"} <= set(expected.status_counts)
    assert set(expected.per_batch) == set(UNITS)
    assert_report_matches(view, expected)
    assert run.err == ""
    assert outputs_left(run.outputs) == [OUTPUT_NAME]


def test_report_settings_take_effect(emu: Emulator, tmp_path: Path) -> None:
    chosen = ["Max speed", "Localization error"]
    toml = (
        "[report]\ntop_n = 3\nregression_window = 4\nregression_threshold = 0.75\n"
        'job_metrics = ["Max speed", "Localization error"]\n'
    )
    run = run_report_cli(emu, tmp_path, toml)
    view = run.view()
    expected = expected_report(emu, top_n=3, window=4, threshold=0.75, job_metrics=chosen)
    defaults = expected_report(emu)
    # Each setting changes what is expected, so a setting left unread would fail below.
    assert len(expected.most_failed) == 3 < len(defaults.most_failed)
    assert len(expected.flips) == 3 < len(defaults.flips)
    assert set(expected.per_batch) == set(chosen) < set(defaults.per_batch)
    assert expected.verdicts != defaults.verdicts
    assert_report_matches(view, expected)
    # The baseline of each judged line is the window's size.
    dist = by_name(view)["Mean distance driven over time"]
    assert "over 4 batches from" in dist.description


def test_an_unknown_job_metric_is_a_configuration_error(emu: Emulator, tmp_path: Path) -> None:
    run = run_report_cli(
        emu, tmp_path, '[report]\njob_metrics = ["Max speed", "Localisation error"]\n'
    )
    assert run.code == 2, run.err
    errors = failure_lines(run.err)
    assert len(errors) == 1, run.err
    assert "'Localisation error'" in errors[0]
    assert "did you mean 'Localization error'" in errors[0]
    assert "Traceback" not in run.err
    assert outputs_left(run.outputs) == []


def test_defaults_off_writes_only_the_summary(emu: Emulator, tmp_path: Path) -> None:
    run = run_report_cli(emu, tmp_path, "[report]\ndefaults = false\n")
    metrics = by_name(run.view())
    assert set(metrics) == {"Report summary"}
    assert text_of(metrics["Report summary"]).startswith(f"{BATCHES} batches of test suite")
