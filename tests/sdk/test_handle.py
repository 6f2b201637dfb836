"""MetricHandle: what a metric method returns, and what it reports."""

from __future__ import annotations

from stook.sdk import MetricsWriter, MetricType, data
from tests.sdk.support import JOB, metric, written


def test_handle_reports_name_type_and_id() -> None:
    w = MetricsWriter(JOB)
    h = w.histogram("h", data.doubles("v", [1.0]), buckets=2, lower=0, upper=1)
    view = written(w)
    assert (h.name, h.type) == ("h", MetricType.HISTOGRAM)
    assert metric(view, "h").id == h.id
    assert [m.name for m in w.metrics] == ["h"]
