"""Jobs whose metrics or data are not what a built-in reads: JobDataError (exit 4) naming the
job. Each case starts from a valid output and breaks one thing in the protobuf."""

from __future__ import annotations

import uuid
from collections.abc import Callable

import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk import MetricsWriter, data, parse_job_metrics, read_metrics_data
from stook.sdk.aggregations import CategoryTotals, JobDataError, JobRecord, MergedHistogram

JOB = uuid.UUID("0a0a0a0a-1111-4222-8333-444444444444")


def histogram_job(change: Callable[[pb.JobMetrics], None]) -> JobRecord:
    w = MetricsWriter(JOB, deterministic=True)
    w.histogram("H", data.doubles("H values", [1.0, 2.0]), buckets=2, lower=0.0, upper=4.0)
    msg = w.to_proto()
    change(msg)
    return JobRecord(JOB, "PASSED", job_metrics=parse_job_metrics(msg))


def values_data(msg: pb.JobMetrics) -> pb.MetricsData:
    return next(d for d in msg.metrics_data if d.name == "H values")


def drop_values(msg: pb.JobMetrics) -> None:
    kept = [d for d in msg.metrics_data if d.name != "H values"]
    del msg.metrics_data[:]
    msg.metrics_data.extend(kept)


def values_as_strings(msg: pb.JobMetrics) -> None:
    d = values_data(msg)
    d.data_type = pb.MetricsDataType.STRING_SERIES_DATA_TYPE
    d.series.ClearField("doubles")
    d.series.strings.series.extend(["a", "b"])


def no_buckets(msg: pb.JobMetrics) -> None:
    del msg.job_level_metrics.metrics[0].metric_values.histogram_metric_values.buckets[:]


def unset_bucket_bound(msg: pb.JobMetrics) -> None:
    hv = msg.job_level_metrics.metrics[0].metric_values.histogram_metric_values
    hv.buckets[1].ClearField("upper")


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (drop_values, "references"),
        (values_as_strings, "holds string, not doubles"),
        (no_buckets, "histogram 'H' has no buckets"),
        (unset_bucket_bound, "metric 'H': bucket 1 has lower 2.0 >= upper 0.0"),
    ],
)
def test_a_broken_histogram_metric_is_job_data_error(
    change: Callable[[pb.JobMetrics], None], message: str
) -> None:
    with pytest.raises(JobDataError, match=message) as info:
        MergedHistogram(name="M", metric="H").update(histogram_job(change))
    assert str(info.value).startswith(f"job {JOB}: ")


def labelled_job(index: data.MetricsData, count: int | None = None) -> JobRecord:
    w = MetricsWriter(JOB, deterministic=True)
    values = data.doubles("d", [1.0, 2.0], index=index)
    w.add_data(values)
    msg = w.to_proto()
    if count is not None:
        own = next(d for d in msg.metrics_data if d.name == "d")
        del own.series.doubles.series[count:]
    views = {d.name: read_metrics_data(d.SerializeToString()) for d in msg.metrics_data}
    return JobRecord(JOB, "PASSED", data=views)


def test_data_indexed_by_timestamps_has_no_categories() -> None:
    record = labelled_job(data.timestamps("t", [1, 2]))
    with pytest.raises(JobDataError, match="not by string labels"):
        CategoryTotals(data="d").update(record)


def test_labels_and_values_of_different_lengths_are_job_data_error() -> None:
    record = labelled_job(data.strings("l", ["a", "b"]), count=1)
    with pytest.raises(JobDataError, match="has 1 values but its labels 'l' have 2"):
        CategoryTotals(data="d").update(record)
