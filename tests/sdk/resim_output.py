"""An output written by ReSim's own writer: every metric type and data kind.

The reader tests read it (through the ``resim_msg`` and ``view`` fixtures of
``conftest.py``), so that what the SDK reads is what the platform's own tools write.
"""

from __future__ import annotations

import uuid

import numpy as np
from resim.metrics.proto import metrics_pb2 as resim_pb
from resim.metrics.python import metrics as rm
from resim.metrics.python.metrics_utils import (
    DoubleFailureDefinition,
    HistogramBucket,
    MetricImportance,
    MetricStatus,
    Timestamp,
)
from resim.metrics.python.metrics_writer import ResimMetricsWriter

JOB_ID = uuid.UUID("11111111-2222-4333-8444-555555555555")
PASSED = MetricStatus.PASSED_METRIC_STATUS
HIGH = MetricImportance.HIGH_IMPORTANCE


def _common(metric: rm.Metric) -> None:
    metric.with_status(PASSED).with_importance(HIGH).with_should_display(True).with_blocking(
        False
    ).with_description("described")


def resim_written() -> resim_pb.JobMetrics:
    """Every metric type and data kind, written by ReSim's own writer."""
    w = ResimMetricsWriter(JOB_ID)
    times = rm.SeriesMetricsData(
        "times", series=np.array([Timestamp(secs=i, nanos=500) for i in range(3)])
    )
    speeds = rm.SeriesMetricsData(
        "speeds", series=np.array([1.0, 2.5, -3.0]), unit="m/s", index_data=times
    )
    speed_statuses = rm.SeriesMetricsData(
        "speed statuses", series=np.array([PASSED] * 3), index_data=times
    )
    m = w.add_double_over_time_metric("Speed")
    m.append_doubles_over_time_data(speeds, "car").append_statuses_over_time_data(speed_statuses)
    m.with_failure_definitions([DoubleFailureDefinition(fails_above=10.0, fails_below=None)])
    m.with_start_time(Timestamp(0, 0)).with_end_time(Timestamp(2, 0)).with_y_axis_name("v")
    _common(m)

    scalar = w.add_scalar_metric("Max speed").with_value(2.5).with_unit("m/s")
    _common(scalar.with_tag("team", "planning"))

    xs = rm.SeriesMetricsData("xs", series=np.array([0.0, 1.0]))
    ys = rm.SeriesMetricsData("ys", series=np.array([4.0, 5.0]))
    xy_statuses = rm.SeriesMetricsData(
        "xy statuses", series=np.array([PASSED, MetricStatus.FAIL_WARN_METRIC_STATUS])
    )
    line = w.add_line_plot_metric("Path").append_series_data(xs, ys, "path")
    _common(line.append_statuses_data(xy_statuses).with_x_axis_name("x").with_y_axis_name("y"))

    bar_names = rm.SeriesMetricsData("bar names", series=np.array(["a", "b"]))
    bar_values = rm.SeriesMetricsData(
        "bar values", series=np.array([1.0, 2.0]), index_data=bar_names
    )
    bar_statuses = rm.SeriesMetricsData(
        "bar statuses", series=np.array([PASSED, PASSED]), index_data=bar_names
    )
    bar = w.add_bar_chart_metric("Bars").append_values_data(bar_values, "v")
    _common(bar.append_statuses_data(bar_statuses).with_stack_bars(True))

    batch_ids = rm.SeriesMetricsData(
        "batch ids", series=np.array([uuid.UUID(int=1), uuid.UUID(int=2)])
    )
    batch_values = rm.SeriesMetricsData(
        "batch values", series=np.array([0.5, 0.75]), index_data=batch_ids
    )
    batch_times = rm.SeriesMetricsData(
        "batch times", series=np.array([Timestamp(1, 0), Timestamp(2, 0)]), index_data=batch_ids
    )
    batch_statuses = rm.SeriesMetricsData(
        "batch statuses", series=np.array([PASSED, PASSED]), index_data=batch_ids
    )
    batch = w.add_batchwise_bar_chart_metric("Batches").with_project_id(uuid.UUID(int=3))
    batch.append_category_data("cat", batch_times, batch_values, batch_statuses)
    _common(batch.with_colors(["#aabbcc"]).with_x_axis_name("t").with_y_axis_name("v"))

    states = rm.SeriesMetricsData(
        "states", series=np.array(["idle", "drive", "idle"]), index_data=times
    )
    state_statuses = rm.SeriesMetricsData(
        "state statuses", series=np.array([PASSED] * 3), index_data=times
    )
    sot = w.add_states_over_time_metric("States").with_states_set({"idle", "drive"})
    sot.append_states_over_time_data(states, "s").append_statuses_over_time_data(state_statuses)
    _common(sot.with_failure_states({"drive"}))

    hist_values = rm.SeriesMetricsData("hist values", series=np.array([0.5, 1.5, 2.0]))
    hist_statuses = rm.SeriesMetricsData("hist statuses", series=np.array([PASSED] * 3))
    hist = w.add_histogram_metric("Histogram").with_values_data(hist_values)
    hist.with_statuses_data(hist_statuses).with_lower_bound(0.0).with_upper_bound(3.0)
    _common(hist.with_buckets([HistogramBucket(0.0, 1.0), HistogramBucket(1.0, 3.0)]))

    summary = w.add_double_summary_metric("Summary").with_value_data(hist_values)
    _common(summary.with_status_data(hist_statuses).with_index(1))

    _common(w.add_plotly_metric("Plot").with_plotly_data('{"data": [{"x": [1, 2]}]}'))
    image = rm.ExternalFileMetricsData("picture", "images/a.png")
    _common(w.add_image_metric("Image").with_image_data(image))
    more = [rm.ExternalFileMetricsData(f"picture {i}", f"images/{i}.png") for i in range(2)]
    _common(w.add_image_list_metric("Images").with_image_list_data(more))
    _common(w.add_text_metric("Text").with_text("# hello"))

    ev_metric = w.add_scalar_metric("Stop speed").with_value(0.0).is_event_metric()
    _common(ev_metric)
    event = w.add_event("Stop").with_absolute_timestamp(Timestamp(7, 9)).with_metrics([ev_metric])
    event.with_status(PASSED).with_importance(HIGH).with_tags(["stops"])

    grouping = rm.SeriesMetricsData("vehicle", series=np.array(["car", "bike", "car"]))
    grouped = speeds.group_by(grouping, "speeds by vehicle", "times by vehicle")
    w.add_metrics_data(grouped)
    return w.write().metrics_msg
