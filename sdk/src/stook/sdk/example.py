"""A test-metrics function that writes every metric type and every kind of metrics data.

It is what `stook demo` runs in test mode, and a template for your own::

    # stook.toml
    [test]
    metrics = "stook.sdk.example:every_metric_type"

The numbers are synthetic (a vehicle speeding up and braking); a real function
would read them from the experience and logs folders it is given.
"""

from __future__ import annotations

import math
import uuid
from datetime import UTC, datetime, timedelta
from pathlib import Path

from stook.sdk import data
from stook.sdk._enums import MetricImportance, MetricStatus, SeriesKind
from stook.sdk._writer import MetricsWriter

_START = datetime(2026, 1, 1, 12, 0, tzinfo=UTC)
_PROJECT = uuid.UUID("7b0e6a4e-2f1d-4c55-9a3e-0d6c2b9f1a11")


def every_metric_type(experience_dir: Path, logs_dir: Path, writer: MetricsWriter) -> None:
    steps = 60
    times = data.timestamps("Time", [_START + timedelta(seconds=0.5 * i) for i in range(steps)])
    speed_values = [12 + 8 * math.sin(i / 9) for i in range(steps)]
    speed = data.doubles("Speed", speed_values, unit="m/s", index=times)
    accel = data.doubles(
        "Acceleration",
        [(speed_values[i] - speed_values[i - 1]) / 0.5 if i else 0.0 for i in range(steps)],
        unit="m/s^2",
        index=times,
    )

    # scalar, computed status from a failure definition
    writer.scalar("Max speed", max(speed_values), unit="m/s", fails_above=25.0).describe(
        "Highest speed over the test"
    ).importance(MetricImportance.HIGH)
    writer.scalar("Min gap to lead vehicle", 4.2, unit="m", fails_below=2.0).tag("area", "safety")

    # double summary: one element picked by its timestamp index
    writer.double_summary(
        "Speed at 10 s", speed, index=_START + timedelta(seconds=10), failure=(30.0, None)
    )
    # double over time, with an explicit status series
    speed_status = data.statuses(
        "Speed status",
        [MetricStatus.FAIL_WARN if v > 19 else MetricStatus.PASSED for v in speed_values],
        index=times,
    )
    writer.double_over_time(
        "Speed over time",
        [speed],
        statuses=[speed_status],
        failures=[(19.0, None)],
        y_axis_name="Speed (m/s)",
    )
    # line plot: speed against acceleration, both plain double series
    writer.line_plot(
        "Speed vs acceleration",
        data.doubles("Speed (x)", speed_values, unit="m/s"),
        data.doubles("Acceleration (y)", [v / 10 for v in speed_values], unit="m/s^2"),
        x_axis_name="Speed",
        y_axis_name="Acceleration",
    )
    # bar chart from labels
    writer.bar_chart_from(
        "Detections per class", {"car": 41.0, "pedestrian": 7.0, "cyclist": 3.0}
    ).describe("Objects detected over the test")
    # states over time
    states = data.strings(
        "Planner state",
        ["cruise" if v < 18 else "slow down" for v in speed_values],
        index=times,
    )
    writer.states_over_time(
        "Planner state over time",
        states,
        states_set=["cruise", "slow down", "stop"],
        failure_states=["stop"],
    )
    # histogram with equal-width buckets
    writer.histogram(
        "Speed distribution",
        data.doubles("Speeds", speed_values, unit="m/s"),
        buckets=10,
        lower=0.0,
        upper=25.0,
        x_axis_name="Speed (m/s)",
    )
    # batchwise bar chart: values per batch over time, indexed by batch IDs
    batch_ids = data.uuids("Batches", [uuid.UUID(int=i + 1) for i in range(3)])
    writer.batchwise_bar_chart(
        "Passed tests per batch",
        project_id=_PROJECT,
        times=[
            data.timestamps(
                "Batch times", [_START - timedelta(days=d) for d in (2, 1, 0)], index=batch_ids
            )
        ],
        values=[data.doubles("Passed tests", [18.0, 19.0, 20.0], index=batch_ids)],
        categories=["PASSED"],
        colors=["#2e7d32"],
        y_axis_name="Tests",
    )
    writer.text("Notes", "Synthetic run: **speed** follows a sine wave.")
    writer.plotly(
        "Speed (plotly)",
        {"data": [{"type": "scatter", "y": speed_values[:10]}], "layout": {"title": "Speed"}},
    )
    # images: files written beside metrics.binproto
    front = data.external_file("Front camera frame", "front.png")
    rear = data.external_file("Rear camera frame", "rear.png")
    writer.image("Front camera", front)
    writer.image_list("Camera frames", [front, rear])

    # metrics data alone, for batch metrics to aggregate later: every remaining kind
    writer.add_data(
        accel,
        data.doubles("speeds", speed_values, unit="m/s"),
        data.uuids("Actor IDs", [uuid.UUID(int=100 + i) for i in range(3)]),
        data.per_category(
            "Detection ranges", SeriesKind.DOUBLE, {"car": [30.5, 42.0], "pedestrian": [12.25]}
        ),
        data.per_category(
            "Detection range statuses",
            SeriesKind.STATUS,
            {
                "car": [MetricStatus.PASSED, MetricStatus.PASSED],
                "pedestrian": [MetricStatus.FAIL_WARN],
            },
        ),
    )

    # an event with its own metric
    brake = writer.scalar("Deceleration at brake", 6.5, unit="m/s^2", event=True)
    writer.event(
        "Hard brake",
        timestamp=_START + timedelta(seconds=21),
        metrics=[brake],
        status=MetricStatus.FAIL_WARN,
        description="Deceleration above 6 m/s^2",
        tags=["braking"],
    )
