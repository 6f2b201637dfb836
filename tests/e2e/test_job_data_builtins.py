"""The job-data built-ins end to end: `stook run` on the emulator, each metric against what the
emulator's ground truth says, computed here in plain Python (no stook code): merged histogram
metrics, per-category totals, event counts, the parameter sweep and the per-tag charts."""

from __future__ import annotations

import math
import uuid
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.emulator import Emulator
from stook.sdk import JobMetricsView, MetricType
from stook.service.cli import run_cli
from stook.service.cli._run import RunOptions, run
from stook.testing import emulated_batch
from tests.e2e.support import (
    EmulatorThread,
    bar_chart,
    by_name,
    config,
    histogram_bounds,
    histogram_values,
    outputs_left,
    read_output,
    text_of,
    write_batch_inputs,
)
from tests.failures import failure_lines

HISTOGRAM = "Acceleration distribution"
DETECTIONS = "Detections per class"
TOML = f"""\
[batch]
defaults = false

[[batch.histogram]]
name = "Accelerations (all jobs)"
metric = "{HISTOGRAM}"

[[batch.category_totals]]
metric = "{DETECTIONS}"
name = "Detections (chart)"

[[batch.category_totals]]
data = "detections per class"
name = "Detections (labelled data)"

[[batch.category_totals]]
data = "detections per class (by category)"
name = "Detections (per category)"

[[batch.events]]

[[batch.sweep]]
parameters = ["max_speed", "planner_mode"]
metrics = ["Braking distance", "Collisions"]

[[batch.by_tag]]
metrics = ["Max speed"]
"""


def bar_series(view: JobMetricsView, name: str) -> dict[str, dict[str, float]]:
    """legend → label → value of a BAR_CHART, read from the proto's references."""
    chart = by_name(view)[name]
    assert chart.type is MetricType.BAR_CHART
    values = chart.raw.metric_values.bar_chart_metric_values
    out = {}
    for legend, ref in zip(values.legend_series_names, values.values_data_id, strict=True):
        data = view.data_by_id[uuid.UUID(ref.id.data)]
        assert data.index_id is not None
        labels = view.data_by_id[data.index_id].series().to_list()
        out[legend] = dict(zip(labels, data.series().to_list(), strict=True))
    return out


def line(view: JobMetricsView, name: str) -> tuple[list[float], list[float]]:
    plot = by_name(view)[name].raw.metric_values.line_plot_metric_values
    (x,), (y,) = plot.x_doubles_data_id, plot.y_doubles_data_id
    return (
        view.data_by_id[uuid.UUID(x.id.data)].series().to_list(),
        view.data_by_id[uuid.UUID(y.id.data)].series().to_list(),
    )


def mean(values: list[float]) -> float:
    return math.fsum(values) / len(values)


@pytest.fixture(scope="module")
def ran(tmp_path_factory: pytest.TempPathFactory) -> tuple[JobMetricsView, Emulator]:
    import asyncio

    tmp = tmp_path_factory.mktemp("job-data")
    (tmp / "stook.toml").write_text(TOML)

    async def go() -> tuple[JobMetricsView, Emulator]:
        async with emulated_batch(tmp / "inputs", jobs_per_batch=48, seed=21) as emu:
            written = await run(
                RunOptions(inputs=tmp / "inputs", outputs=tmp / "out", config=tmp / "stook.toml")
            )
            return read_output(written), emu

    return asyncio.run(go())


def test_histogram_metrics_merge_on_the_jobs_buckets(ran: tuple[JobMetricsView, Emulator]) -> None:
    view, emu = ran
    truths = [t for _, t in emu.dataset.job_truths(emu.batch_id) if HISTOGRAM in t.histograms]
    assert len(truths) > 30
    expected = sorted(v for t in truths for v in t.histograms[HISTOGRAM].values)
    metric = by_name(view)["Accelerations (all jobs)"]
    assert histogram_values(view, metric) == expected
    (buckets,) = {t.histograms[HISTOGRAM].buckets for t in truths}
    lower, upper, written = histogram_bounds(view, metric)
    assert written == list(buckets)
    assert (lower, upper, len(written)) == (-8.0, 8.0, 16)
    x_axis = metric.raw.metric_values.histogram_metric_values.x_axis_name
    assert x_axis == "Acceleration (m/s^2)"


def test_category_totals_from_a_chart_labelled_data_and_per_category_data(
    ran: tuple[JobMetricsView, Emulator],
) -> None:
    view, emu = ran
    truths = [t for _, t in emu.dataset.job_truths(emu.batch_id)]
    labelled = [t.labelled["detections per class"] for t in truths if t.labelled]
    totals: dict[str, float] = {}
    for counts in labelled:
        for label, value in counts.items():
            totals[label] = totals.get(label, 0.0) + value
    expected = dict(sorted(totals.items()))
    means = {label: total / len(labelled) for label, total in expected.items()}
    assert set(expected) == {"bus", "car", "cyclist", "pedestrian", "truck"}
    assert bar_series(view, "Detections (chart)") == {"detections per class": expected}
    assert bar_series(view, "Detections (chart) (mean per job)") == {
        "detections per class": pytest.approx(means, rel=1e-12)
    }
    assert bar_series(view, "Detections (labelled data)") == {"detections per class": expected}
    # The per-category data splits the same counts over the run's quarters.
    per_category = [
        t.per_category["detections per class (by category)"] for t in truths if t.labelled
    ]
    split: dict[str, float] = {}
    for windows in per_category:
        for label, values in windows.items():
            split[label] = split.get(label, 0.0) + math.fsum(values)
    assert split == totals
    assert bar_series(view, "Detections (per category)") == {
        "detections per class (by category)": expected
    }


def test_events_counted_by_name_and_status(ran: tuple[JobMetricsView, Emulator]) -> None:
    view, emu = ran
    counts: Counter[tuple[str, str]] = Counter()
    for _, truth in emu.dataset.job_truths(emu.batch_id):
        counts.update((e.name, e.status) for e in truth.events)
    assert len({s for _, s in counts}) >= 2
    names = sorted({n for n, _ in counts})
    order = ["PASSED", "FAIL_WARN", "FAIL_BLOCK", "NOT_APPLICABLE", "RAW", "NO_STATUS_REPORTED"]
    statuses = [s for s in order if any(st == s for _, st in counts)]
    expected = {s: {n: float(counts[n, s]) for n in names} for s in statuses}
    chart = bar_series(view, "Events by name and status")
    assert list(chart) == statuses
    assert chart == expected
    assert by_name(view)[
        "Events by name and status"
    ].raw.metric_values.bar_chart_metric_values.stack_bars


def test_sweep_table_and_lines(ran: tuple[JobMetricsView, Emulator]) -> None:
    view, emu = ran
    rows: dict[tuple[str, str], list[dict[str, float]]] = {}
    for job, truth in emu.dataset.job_truths(emu.batch_id):
        key = (job.parameter_map["max_speed"], job.parameter_map["planner_mode"])
        rows.setdefault(key, []).append(truth.scalars)
    assert len(rows) == 8
    lines = [
        "| max_speed | planner_mode | jobs | Braking distance (mean, m) | Collisions (mean) |",
        "|---|---|---|---|---|",
    ]
    for key in sorted(rows, key=lambda k: (float(k[0]), k[1])):
        cells = [*key, str(len(rows[key]))]
        for metric in ("Braking distance", "Collisions"):
            values = [s[metric] for s in rows[key] if metric in s]
            cells.append(f"{mean(values):.6g}" if values else "–")
        lines.append("| " + " | ".join(cells) + " |")
    text = text_of(by_name(view)["Parameter sweep"])
    assert text.splitlines()[2:] == lines

    braking: dict[float, list[float]] = {}
    for (speed, _), scalars in rows.items():
        braking.setdefault(float(speed), []).extend(
            s["Braking distance"] for s in scalars if "Braking distance" in s
        )
    xs, ys = line(view, "Parameter sweep: Braking distance by max_speed")
    assert xs == sorted(braking) == [10.0, 15.0, 20.0, 25.0]
    assert ys == pytest.approx([mean(braking[x]) for x in xs], rel=1e-12)
    assert ys == sorted(ys)  # braking distance rises with the speed cap
    by_mode = bar_chart(view, by_name(view)["Parameter sweep: Collisions by planner_mode"])
    collisions: dict[str, list[float]] = {}
    for (_, mode), scalars in rows.items():
        collisions.setdefault(mode, []).extend(
            s["Collisions"] for s in scalars if "Collisions" in s
        )
    assert by_mode == pytest.approx({m: mean(v) for m, v in sorted(collisions.items())}, rel=1e-12)


def test_pass_rate_and_means_per_experience_tag(ran: tuple[JobMetricsView, Emulator]) -> None:
    view, emu = ran
    jobs: Counter[str] = Counter()
    passed: Counter[str] = Counter()
    speeds: dict[str, list[float]] = {}
    for job, truth in emu.dataset.job_truths(emu.batch_id):
        tags = sorted({t.name for t in job.experience.tags}) or ["(untagged)"]
        for tag in tags:
            jobs[tag] += 1
            passed[tag] += job.conflated_status == "PASSED"
            if "Max speed" in truth.scalars:
                speeds.setdefault(tag, []).append(truth.scalars["Max speed"])
    assert len(jobs) >= 3
    rates = bar_chart(view, by_name(view)["Pass rate by experience tag"])
    assert rates == pytest.approx({t: 100.0 * passed[t] / jobs[t] for t in sorted(jobs)})
    assert list(rates) == sorted(jobs)
    means = bar_chart(view, by_name(view)["Max speed (mean) by experience tag"])
    assert means == pytest.approx({t: mean(v) for t, v in sorted(speeds.items())}, rel=1e-12)


@pytest.fixture(scope="module")
def mismatched() -> Iterator[Emulator]:
    with EmulatorThread(
        config(jobs_per_batch=12, seed=4, histogram_bucket_mismatch_jobs=(5,))
    ) as emulator:
        yield emulator


@pytest.mark.usefixtures("isolated")
def test_histograms_on_differing_buckets_are_exit_4_naming_two_jobs(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, mismatched: Emulator
) -> None:
    write_batch_inputs(tmp_path / "inputs", mismatched)
    toml = tmp_path / "stook.toml"
    toml.write_text(f'[[batch.histogram]]\nname = "A"\nmetric = "{HISTOGRAM}"\n')
    argv = ["run", "--inputs", str(tmp_path / "inputs"), "--outputs", str(tmp_path / "out")]
    code = run_cli([*argv, "--config", str(toml), "--log-format", "json"])
    err = capsys.readouterr().err
    assert code == 4, err
    (message,) = failure_lines(err)
    jobs = {job.index: job for job in mismatched.dataset.jobs(mismatched.batch_id)}
    named = [j for j in jobs.values() if str(j.id) in message]
    assert len(named) == 2, message
    assert jobs[5] in named
    assert "different buckets (16 from -8 to 8 vs 20 from -10 to 10)" in message or (
        "different buckets (20 from -10 to 10 vs 16 from -8 to 8)" in message
    )
    assert "Traceback" not in err
    assert outputs_left(tmp_path / "out") == []


@pytest.mark.usefixtures("isolated")
def test_a_metric_no_job_has_is_exit_2_with_a_suggestion(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, mismatched: Emulator
) -> None:
    write_batch_inputs(tmp_path / "inputs", mismatched)
    toml = tmp_path / "stook.toml"
    toml.write_text('[[batch.category_totals]]\nmetric = "Detections per clas"\n')
    argv = ["run", "--inputs", str(tmp_path / "inputs"), "--outputs", str(tmp_path / "out")]
    code = run_cli([*argv, "--config", str(toml), "--log-format", "json"])
    err = capsys.readouterr().err
    assert code == 2, err
    (message,) = failure_lines(err)
    assert message.endswith(
        "no job in the batch has a job metric named 'Detections per clas'; "
        "did you mean 'Detections per class'?"
    ), message
    assert outputs_left(tmp_path / "out") == []
