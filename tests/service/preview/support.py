"""Outputs to preview, and what each chart metric should draw, read from the file itself."""

from __future__ import annotations

import uuid
from pathlib import Path
from typing import Any

from google.protobuf.json_format import MessageToDict

from stook.proto import metrics_pb2 as pb
from stook.sdk import JobMetricsView, MetricsWriter, MetricType
from stook.sdk.example import every_metric_type
from stook.testing._frames import write_example_frames

GOLDEN = Path(__file__).resolve().parents[2] / "golden"
BATCH_OUTPUT = GOLDEN / "batch_configured.binproto"
REPORT_OUTPUT = GOLDEN / "report_defaults.binproto"


def write_example(folder: Path, *, frames: bool = True) -> Path:
    """The SDK's every-metric-type example as a file, with its images beside it."""
    folder.mkdir(parents=True, exist_ok=True)
    writer = MetricsWriter(uuid.UUID(int=7))
    every_metric_type(folder, folder, writer)
    path = writer.write(folder / "metrics.binproto")
    if frames:
        write_example_frames(folder)
    return path


def _lengths(view: JobMetricsView, refs: Any) -> list[int]:
    out = []
    for ref in refs:
        data = view.data_by_id[uuid.UUID(hex=ref.id.data)]
        which = data.raw.series.WhichOneof("series")
        out.append(len(getattr(data.raw.series, which).series) if which else 0)
    return out


def expected_points(view: JobMetricsView) -> dict[str, list[int]]:
    """Per chart metric: the number of points of each trace it should draw."""
    expected: dict[str, list[int]] = {}
    for metric in view.metrics:
        values = metric.raw.metric_values
        match metric.type:
            case MetricType.DOUBLE_OVER_TIME:
                mv = values.double_over_time_metric_values
                expected[metric.name] = _lengths(view, mv.doubles_over_time_data_id)
            case MetricType.LINE_PLOT:
                expected[metric.name] = _lengths(
                    view, values.line_plot_metric_values.y_doubles_data_id
                )
            case MetricType.BAR_CHART:
                expected[metric.name] = _lengths(
                    view, values.bar_chart_metric_values.values_data_id
                )
            case MetricType.BATCHWISE_BAR_CHART:
                mv2 = values.batchwise_bar_chart_metric_values
                expected[metric.name] = _lengths(view, mv2.values_data_id)
            case MetricType.STATES_OVER_TIME:
                mv3 = values.states_over_time_metric_values
                expected[metric.name] = _lengths(view, mv3.states_over_time_data_id)
            case MetricType.HISTOGRAM:
                expected[metric.name] = [len(values.histogram_metric_values.buckets)]
            case MetricType.PLOTLY:
                figure = MessageToDict(values.plotly_metric_values.json)
                expected[metric.name] = [len(t.get("y", t.get("x", []))) for t in figure["data"]]
    return expected


def job_metrics(*metrics: pb.Metric) -> pb.JobMetrics:
    msg = pb.JobMetrics()
    msg.job_id.id.data = str(uuid.UUID(int=1))
    for metric in metrics:
        msg.job_level_metrics.metrics.append(metric)
    return msg
