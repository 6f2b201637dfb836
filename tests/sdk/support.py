"""Helpers of the SDK tests: a known job, and writing an output then reading it back.

`written` checks every output three ways: stook's validator, ReSim's validator (the
oracle) and the SDK reader, whose views must give back exactly what was written.
"""

from __future__ import annotations

import re
import uuid
from array import array
from collections.abc import Iterable
from contextlib import AbstractContextManager
from datetime import UTC, datetime, timedelta

import pytest
import resim.metrics.proto.metrics_pb2 as rp
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.proto import metrics_pb2 as pb
from stook.sdk import (
    JobMetricsView,
    MetricsDataView,
    MetricsWriter,
    MetricView,
    WriterError,
    find_problems,
    read_job_metrics,
)

JOB = uuid.UUID("0b7a4c1e-5d2f-4e8a-9c3b-6f1d2e3a4b5c")
OTHER_JOB = uuid.UUID("9e8d7c6b-5a49-4382-9170-6f5e4d3c2b1a")
PROJECT = uuid.UUID("7b0e6a4e-2f1d-4c55-9a3e-0d6c2b9f1a11")
T0 = datetime(2026, 1, 1, 12, 0, tzinfo=UTC)
T0_NS = 1_767_268_800 * 1_000_000_000


def epoch_ns(dt: datetime) -> int:
    return int((dt - datetime(1970, 1, 1, tzinfo=UTC)) / timedelta(microseconds=1)) * 1_000


def resim_accepts(payload: bytes) -> None:
    resim_validate(rp.JobMetrics.FromString(payload))


def written(w: MetricsWriter) -> JobMetricsView:
    """Serialize, check both validators accept, read back."""
    payload = w.serialize()
    problems = find_problems(w.to_proto())
    assert problems == [], "\n".join(map(str, problems))
    resim_accepts(payload)
    view = read_job_metrics(payload)
    assert view.job_id == w.job_id
    return view


def metric(view: JobMetricsView, name: str) -> MetricView:
    found = [m for m in view.metrics if m.name == name]
    assert len(found) == 1, f"{len(found)} metrics named {name!r}"
    return found[0]


def data_of(view: JobMetricsView, ref: pb.MetricsDataId) -> MetricsDataView:
    return view.data_by_id[uuid.UUID(ref.id.data)]


def data_names(items: Iterable[MetricsDataView]) -> list[str]:
    return [d.name for d in items]


def names_of(view: JobMetricsView, refs: object) -> list[str]:
    return [data_of(view, r).name for r in refs]  # type: ignore[attr-defined]


def statuses_of(d: MetricsDataView) -> list[str]:
    return d.series().to_list()


def float_bits(values: Iterable[float]) -> bytes:
    return array("d", values).tobytes()


def writer_error(match: str) -> AbstractContextManager[pytest.ExceptionInfo[WriterError]]:
    return pytest.raises(WriterError, match=re.escape(match))


def bare_data(kind: int, **fields: object) -> pb.MetricsData:
    """A MetricsData message of `kind` with a random ID and nothing else, to fill by hand."""
    d = pb.MetricsData(data_type=kind, name="d", **fields)  # type: ignore[arg-type]
    d.metrics_data_id.id.data = str(uuid.uuid4())
    return d
