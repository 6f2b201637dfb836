"""Fixtures of the SDK tests: ReSim's own output, as bytes and as the SDK reads it."""

from __future__ import annotations

import pytest
from resim.metrics.proto import metrics_pb2 as resim_pb

from stook.sdk import JobMetricsView, read_job_metrics
from tests.sdk.resim_output import resim_written


@pytest.fixture(scope="module")
def resim_msg() -> resim_pb.JobMetrics:
    return resim_written()


@pytest.fixture(scope="module")
def view(resim_msg: resim_pb.JobMetrics) -> JobMetricsView:
    return read_job_metrics(resim_msg.SerializeToString(), source="resim.binproto")
