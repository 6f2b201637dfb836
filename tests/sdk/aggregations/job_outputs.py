"""Hand-made jobs whose metrics and data are real: written by MetricsWriter, serialized,
and read back with read_job_metrics, as the fetcher hands them to aggregations."""

from __future__ import annotations

import uuid
from collections.abc import Mapping, Sequence

from stook.sdk import (
    MetricsWriter,
    MetricType,
    SeriesKind,
    data,
    read_job_metrics,
    read_metrics_data,
)
from stook.sdk.aggregations import JobEvent, JobRecord, Scalar
from tests.sdk.aggregations.support import Output

Buckets = Sequence[tuple[float, float]]


def job_with(
    status: str = "PASSED",
    *,
    histogram: tuple[str, Sequence[float], Buckets] | None = None,
    bars: tuple[str, Mapping[str, Mapping[str, float]]] | None = None,
    per_category: tuple[str, Mapping[str, Sequence[float]]] | None = None,
    labelled: tuple[str, Sequence[str], Sequence[float]] | None = None,
    with_labels: bool = True,
    scalars: Mapping[str, Scalar | float] | None = None,
    parameters: Mapping[str, str] | None = None,
    events: Sequence[tuple[str, str]] = (),
    tags: Sequence[str] = (),
    job_id: uuid.UUID | None = None,
    x_axis_name: str | None = None,
) -> JobRecord:
    """A job with (some of): a HISTOGRAM metric (name, values, buckets); a BAR_CHART
    (name, legend → label → value); per-category doubles (name, category → values);
    doubles indexed by string labels (name, labels, values), its labels' data named
    "<name> labels" and attached as its index unless `with_labels` is false; events
    (name, status)."""
    job_id = job_id or uuid.uuid4()
    w = MetricsWriter(job_id, deterministic=True)
    names: list[str] = []
    if histogram is not None:
        name, values, buckets = histogram
        w.histogram(
            name,
            data.doubles(f"{name} values", values),
            buckets=list(buckets),
            x_axis_name=x_axis_name,
        )
    if bars is not None:
        name, by_legend = bars
        series = []
        for legend, by_label in by_legend.items():
            index = data.strings(f"{name} {legend} labels", list(by_label))
            series.append(data.doubles(f"{name} {legend}", list(by_label.values()), index=index))
        w.bar_chart(name, series, legend=list(by_legend))
    if per_category is not None:
        name, by_category = per_category
        w.add_data(data.per_category(name, SeriesKind.DOUBLE, by_category))
        names.append(name)
    indexed: list[str] = []
    if labelled is not None:
        name, labels, values = labelled
        w.add_data(data.doubles(name, values, index=data.strings(f"{name} labels", labels)))
        names.append(name)
        if with_labels:
            indexed.append(name)
    view = read_job_metrics(w.serialize())
    # Data asked for by name is read alone, as the fetcher does: without its index, unless
    # asked for with it (Needs.data_with_index), which the fetcher then attaches.
    alone = {
        name: read_metrics_data(view.data_by_name[name].raw.SerializeToString()) for name in names
    }
    for name in indexed:
        index_id = view.data_by_name[name].index_id
        assert index_id is not None
        index_view = view.data_by_id[index_id]
        alone[name] = alone[name].with_index(read_metrics_data(index_view.raw.SerializeToString()))
    return JobRecord(
        job_id=job_id,
        conflated_status=status,
        scalars={
            k: v if isinstance(v, Scalar) else Scalar(float(v)) for k, v in (scalars or {}).items()
        },
        data=alone,
        job_metrics=view if view.metrics else None,
        parameters=dict(parameters or {}),
        events=tuple(
            JobEvent(event_id=uuid.uuid4(), name=name, status=event_status)
            for name, event_status in events
        ),
        experience_tags=tuple(sorted(tags)),
    )


def bar_series(out: Output, name: str) -> dict[str, dict[str, float]]:
    """legend → label → value of every series of a BAR_CHART."""
    m = out.metric(name, MetricType.BAR_CHART)
    bv = m.raw.metric_values.bar_chart_metric_values
    found = {}
    for legend, ref in zip(bv.legend_series_names, bv.values_data_id, strict=True):
        values = out.view.data_by_id[uuid.UUID(ref.id.data)]
        assert values.index_id is not None
        labels = out.view.data_by_id[values.index_id].series().to_list()
        found[legend] = dict(zip(labels, values.series().to_list(), strict=True))
    return found
