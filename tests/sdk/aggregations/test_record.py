"""JobRecord.metric: the typed view of one of the job's metrics, or None."""

from __future__ import annotations

import uuid

import pytest

from stook.sdk import (
    HistogramMetric,
    JobMetricsView,
    MetricsWriter,
    TextMetric,
    data,
    read_job_metrics,
)
from stook.sdk.aggregations import JobRecord


def job_metrics() -> JobMetricsView:
    w = MetricsWriter(uuid.uuid4())
    w.histogram("Speeds", data.doubles("speeds", [1.0, 3.0]), buckets=2, lower=0, upper=4)
    return read_job_metrics(w.serialize())


def test_a_record_hands_out_typed_metrics() -> None:
    record = JobRecord(uuid.uuid4(), "PASSED", job_metrics=job_metrics())
    hist = record.metric("Speeds", HistogramMetric)
    assert hist is not None
    assert hist.values_data is not None
    assert hist.values_data.values() == (1.0, 3.0)
    assert isinstance(record.metric("Speeds"), HistogramMetric)
    with pytest.raises(TypeError, match="not a TextMetric"):
        record.metric("Speeds", TextMetric)


def test_no_such_metric_or_no_job_metrics_is_none() -> None:
    assert JobRecord(uuid.uuid4(), "PASSED", job_metrics=job_metrics()).metric("Other") is None
    assert JobRecord(uuid.uuid4(), "PASSED").metric("Speeds") is None
