"""The fixture config evaluated offline at the three levels, through `stook
metrics-config eval`; every metric's numbers against a plain-Python computation of the
rows ReSim's Emitter wrote."""

from __future__ import annotations

import itertools
import math
import statistics
from decimal import Decimal
from pathlib import Path

import pytest

from stook.sdk import (
    BarChartMetric,
    HistogramMetric,
    ImageMetric,
    LinePlotMetric,
    MetricStatus,
    PlotlyMetric,
    ScalarMetric,
    StatesOverTimeMetric,
    TextMetric,
    read_job_metrics,
    validate_job_metrics,
)
from stook.service.cli._main import run_cli
from tests.service.metrics_config.conftest import BATCH_META
from tests.service.metrics_config.emitted import JobData


def _eval(config: Path, emissions: Path, out: Path, level: str, *extra: str) -> int:
    return run_cli(
        [
            "metrics-config",
            "eval",
            str(config),
            "--emissions",
            str(emissions),
            "--level",
            level,
            "--outputs",
            str(out),
            *extra,
        ]
    )


def test_test_level_metrics_equal_a_plain_computation(
    tmp_path: Path, config: Path, one_job: tuple[Path, JobData]
) -> None:
    emissions, job = one_job
    out = tmp_path / "out"
    assert _eval(config, emissions, out, "test") == 0
    view = read_job_metrics((out / "metrics.binproto").read_bytes())
    validate_job_metrics(view.raw)
    speeds = [s for _, _, s in job.speed]

    # line: one series per lane, x in seconds, axis titles from the aliases
    line = view.metric("Speed over time", LinePlotMetric)
    assert line.legend == ("left", "right")
    assert (line.x_axis_name, line.y_axis_name) == ("Time (s)", "Speed (m/s)")
    for lane, xs, ys in zip(line.legend, line.x_doubles_data, line.y_doubles_data, strict=True):
        points = sorted((t, s) for ln, t, s in job.speed if ln == lane)
        assert list(xs.values()) == [t / 1e9 for t, _ in points]
        assert list(ys.values()) == [s for _, s in points]

    # scalar with a status: 8 + 2.5 + 1.5*2 - 0.25*4 ... below 20 -> PASSED
    top = view.metric("Max speed", ScalarMetric)
    assert top.value == max(speeds)
    assert top.unit == "m/s"
    assert top.status is (MetricStatus.PASSED if max(speeds) <= 20 else MetricStatus.FAIL_WARN)

    # bar: groups (confidence) x categories (label)
    bar = view.metric("Detections by label", BarChartMetric)
    expected: dict[str, dict[str, float]] = {}
    for label, count, confident in job.detections:
        group = expected.setdefault("confident" if confident else "unsure", {})
        group[label] = group.get(label, 0) + count
    assert bar.legend == tuple(sorted(expected))
    for name, series in zip(bar.legend, bar.values_data, strict=True):
        assert dict(series.labelled()) == dict(sorted(expected[name].items()))

    # histogram: bins from template_settings.display.bins, every value counted
    hist = view.metric("Speed distribution", HistogramMetric)
    assert len(hist.buckets) == 10
    assert (hist.lower_bound, hist.upper_bound) == (min(speeds), max(speeds))
    assert hist.values_data is not None
    assert sorted(hist.values_data.values()) == sorted(speeds)

    states = view.metric("Planner states", StatesOverTimeMetric)
    assert states.legend == ("planner",)
    assert [s for s in states.states_over_time_data[0].labelled()] == [
        (at, state) for at, state in job.states
    ]

    pie = view.metric("Detection share", PlotlyMetric)
    totals: dict[str, float] = {}
    for label, count, _ in job.detections:
        totals[label] = totals.get(label, 0) + count
    assert pie.json["data"][0]["labels"] == sorted(totals)
    assert pie.json["data"][0]["values"] == [totals[k] for k in sorted(totals)]

    table = view.metric("Speed summary", TextMetric).text.splitlines()
    assert table[0] == "| Lane | Samples | Mean speed | Top speed |"
    for lane, row in zip(("left", "right"), table[2:], strict=True):
        lane_speeds = [s for ln, _, s in job.speed if ln == lane]
        mean = round(statistics.fmean(lane_speeds), 3)
        # CAST(DOUBLE AS VARCHAR) is Trino's text: scientific, shortest digits (1.025E1).
        top_speed = f"{Decimal(repr(max(lane_speeds))).normalize():E}".replace("E+", "E")
        assert row == f"| {lane} | {len(lane_speeds)} | {mean} | {top_speed} m/s |"

    image = view.metric("Camera frame", ImageMetric)
    assert image.image_data is not None
    assert image.image_data.external_path == job.frame
    assert (out / job.frame).is_file()

    figure = view.metric("Speed figure", PlotlyMetric).json
    for trace, lane in zip(figure["data"], ("left", "right"), strict=True):
        assert trace["name"] == lane
        assert trace["y"] == [s for ln, _, s in job.speed if ln == lane]

    # absence: the lidar emitted nothing
    assert view.find_metric("Lidar dropouts") is None  # skip_if_no_data: hidden
    dropout = view.find_metric("Worst lidar dropout")  # MAX over nothing: NO_DATA
    assert dropout is not None
    assert dropout.status is MetricStatus.NOT_APPLICABLE  # its blocking status did not run
    assert ("no_data", "true") in dropout.tags
    samples = view.metric("Lidar samples", ScalarMetric)  # COUNT(*): a row of 0
    assert samples.value == 0
    assert samples.status is MetricStatus.FAIL_BLOCK
    assert samples.view.blocking is True

    # the event topic's row became an event with its metric
    (event,) = view.events
    collision = job.collisions[0]
    assert (event.name, event.description, event.tags) == (
        collision["name"],
        collision["description"],
        tuple(collision["tags"]),
    )
    assert event.status is MetricStatus.FAIL_WARN
    assert event.timestamp_ns == 1_500_000_000
    impact = view.metrics_by_id[event.metric_ids[0]]
    assert (impact.name, impact.value, impact.unit) == ("impact speed", 3.5, "m/s")

    # only the test level's metrics; the absent lidar's COUNT(*) blocks the test
    assert view.find_metric("Max speed per experience") is None
    assert view.status is MetricStatus.FAIL_BLOCK


def test_batch_level_joins_metadata_and_blocks(
    tmp_path: Path, config: Path, batch: tuple[Path, list[JobData]]
) -> None:
    folder, jobs = batch
    out = tmp_path / "out"
    assert _eval(config, folder, out, "batch") == 0
    view = read_job_metrics((out / "metrics.binproto").read_bytes())
    tops = {job.name: max(s for _, _, s in job.speed) for job in jobs}

    per_exp = view.metric("Max speed per experience", BarChartMetric)
    assert dict(per_exp.values_data[0].labelled()) == dict(sorted(tops.items()))

    over = view.metric("Jobs over the limit", ScalarMetric)
    count = sum(1 for t in tops.values() if t > 25)
    assert over.value == count
    expected = (
        MetricStatus.FAIL_BLOCK
        if count >= 2
        else MetricStatus.FAIL_WARN
        if count >= 1
        else MetricStatus.PASSED
    )
    assert over.status is expected

    jumps = []
    for job in jobs:
        for lane in ("left", "right"):
            lane_speeds = [s for ln, _, s in sorted(job.speed) if ln == lane]
            jumps += [b - a for a, b in itertools.pairwise(lane_speeds)]
    assert view.metric("Largest speed jump", ScalarMetric).value == pytest.approx(max(jumps))

    everything = [s for job in jobs for _, _, s in job.speed]
    median = view.metric("Median speed", ScalarMetric).value
    assert median is not None
    ordered = sorted(everything)  # approximate: within one neighbour of the median
    assert ordered[len(ordered) // 2 - 1] <= median <= ordered[len(ordered) // 2]

    outcomes = view.metric("Job outcomes", TextMetric).text.splitlines()[2:]
    statuses: dict[str, int] = {}
    for meta in BATCH_META:
        key = f"status {meta['job_conflated_status']}"
        statuses[key] = statuses.get(key, 0) + 1
    rows = sorted([*statuses.items(), ("all", len(BATCH_META))])
    assert outcomes == [f"| {k} | {v} |" for k, v in rows]

    collisions = view.metric("Collisions", ScalarMetric)
    n = sum(len(job.collisions) for job in jobs)
    assert collisions.value == n
    assert collisions.status is (MetricStatus.FAIL_WARN if n >= 1 else MetricStatus.PASSED)
    assert view.events == ()  # a batch output has no events
    assert view.status is (MetricStatus.FAIL_BLOCK if count >= 2 else view.status)


def test_dashboard_level_groups_by_build_version(
    tmp_path: Path, config: Path, batch: tuple[Path, list[JobData]]
) -> None:
    folder, jobs = batch
    out = tmp_path / "out"
    assert _eval(config, folder, out, "dashboard") == 0
    view = read_job_metrics((out / "metrics.binproto").read_bytes())
    assert view.metric_names() == ("Max speed by version",)
    by_version: dict[str, float] = {}
    for job, meta in zip(jobs, BATCH_META, strict=True):
        top = max(s for _, _, s in job.speed)
        by_version[meta["build_version"]] = max(
            by_version.get(meta["build_version"], -math.inf), top
        )
    bar = view.metric("Max speed by version", BarChartMetric)
    assert dict(bar.values_data[0].labelled()) == by_version
    assert (bar.x_axis_name, bar.y_axis_name) == ("Version", "Max speed")


def test_a_metrics_set_chooses_the_metrics(
    tmp_path: Path, config: Path, one_job: tuple[Path, JobData]
) -> None:
    emissions, _ = one_job
    out = tmp_path / "out"
    assert _eval(config, emissions, out, "test", "--metrics-set", "core") == 0
    view = read_job_metrics((out / "metrics.binproto").read_bytes())
    assert {m.name for m in view.metrics if not m.event_metric} == {
        "Max speed",
        "Speed over time",
        "Detections by label",
        "Worst lidar dropout",
    }


def test_the_same_inputs_give_the_same_bytes(
    tmp_path: Path, config: Path, batch: tuple[Path, list[JobData]]
) -> None:
    folder, _ = batch
    assert _eval(config, folder, tmp_path / "a", "batch") == 0
    assert _eval(config, folder, tmp_path / "b", "batch") == 0
    first = (tmp_path / "a" / "metrics.binproto").read_bytes()
    assert first == (tmp_path / "b" / "metrics.binproto").read_bytes()


def test_preview_is_written(tmp_path: Path, config: Path, one_job: tuple[Path, JobData]) -> None:
    emissions, _ = one_job
    out = tmp_path / "out"
    assert _eval(config, emissions, out, "test", "--preview") == 0
    assert "Speed over time" in (out / "metrics.html").read_text(encoding="utf-8")


def test_templates_from_another_folder(
    tmp_path: Path, config: Path, one_job: tuple[Path, JobData]
) -> None:
    emissions, _ = one_job
    elsewhere = tmp_path / "elsewhere"
    (config.parent / "templates").rename(elsewhere)
    out = tmp_path / "out"
    assert run_cli(["metrics-config", "check", str(config)]) == 2  # not beside the config
    assert run_cli(["metrics-config", "check", str(config), "--templates", str(elsewhere)]) == 0
    assert _eval(config, emissions, out, "test", "--templates", str(elsewhere)) == 0
    view = read_job_metrics((out / "metrics.binproto").read_bytes())
    assert view.find_metric("Speed figure") is not None
