"""Answers the API spec allows but a tidy server would not give, for clients to cope with.

The spec's ``job``, ``batch``, ``metric`` and ``metricsData`` schemas require no field, a
metric's ``value`` is nullable and its enums may grow; ReSim's Go server omits empty fields
and writes nanosecond timestamps. With ``spec_quirks`` on, the emulator answers that way
everywhere, changing nothing a correct client computes:

* empty fields (null, "", false, [] and {}) are left out, as Go's ``omitempty`` does;
* about half the SCALAR metrics are listed with ``value: null``; their value is only in
  the serialized ``Metric`` message at ``metricURL``;
* enum fields that no default metric reads carry values the spec does not list yet
  (a job's ``jobStatus`` and ``jobMetricsStatus``; a batch's statuses);
* every job has two more metrics data: one without a name or a type (a valid, unnamed
  ``MetricsData``) and one of a storage type the spec does not list;
* timestamps carry nine fractional digits (RFC3339Nano), and the first job of a batch
  was created in a leap second (``23:59:60``, which RFC 3339 allows).

Two more settings change what a client must compute, so that tests can check the counts:
the jobs of ``future_status_jobs`` are listed with a conflated status and metric statuses
the spec does not list, and those of ``unreported_status_jobs`` without either.
"""

from __future__ import annotations

import uuid
from collections.abc import Mapping
from datetime import datetime
from typing import Any

from stook.emulator._config import EmulatorConfig
from stook.emulator._store import MetricsOutput, StoredData, StoredMetric
from stook.emulator._world import JobSpec
from stook.proto import metrics_pb2 as pb

Json = dict[str, Any]

# Statuses the spec does not list (yet); a client must count them under these names.
FUTURE_CONFLATED_STATUS = "FLAKY"
FUTURE_METRIC_STATUS = "FAIL_SOFT"
# Enum values on fields no default metric reads, served with spec_quirks.
_FUTURE_JOB_STATUS = "RETRIED"
_FUTURE_BATCH_STATUS = "ARCHIVED"
_FUTURE_STORAGE_TYPE = "POINT_CLOUD"
_BATCH_METRIC_STATUS_KEYS = ("batchMetricsStatus", "jobsMetricsStatus", "overallMetricsStatus")
# Sub-microsecond digits: a client keeps microseconds, so they change nothing.
_EXTRA_NANOS = "789"
# The first job's creation time: a leap second (no output depends on a job's creation time).
LEAP_SECOND = "2016-12-31T23:59:60Z"

UNNAMED_DATA = "unnamed data"
POINT_CLOUD_DATA = "Point cloud"


class SpecQuirks:
    """Rewrites the emulator's JSON objects (and adds metrics data) per the config."""

    def __init__(self, config: EmulatorConfig) -> None:
        self.on = config.spec_quirks
        self._future = frozenset(config.future_status_jobs)
        self._unreported = frozenset(config.unreported_status_jobs)

    # ---- the objects ----

    def job(self, spec: JobSpec, body: Json) -> Json:
        if spec.index in self._future:
            body["conflatedStatus"] = FUTURE_CONFLATED_STATUS
        elif spec.index in self._unreported:
            del body["conflatedStatus"]
        if not self.on:
            return body
        body["jobStatus"] = _FUTURE_JOB_STATUS
        body["jobMetricsStatus"] = FUTURE_METRIC_STATUS
        body = self._tidy(body)
        if spec.index == 0:
            body["creationTimestamp"] = LEAP_SECOND
        return body

    def batch(self, body: Json) -> Json:
        if not self.on:
            return body
        body["status"] = body["conflatedStatus"] = _FUTURE_BATCH_STATUS
        for key in _BATCH_METRIC_STATUS_KEYS:
            body[key] = FUTURE_METRIC_STATUS
        return self._tidy(body)

    def metric(self, metric: StoredMetric, body: Json, job: JobSpec | None = None) -> Json:
        """A job metric (with its job) or a batch metric."""
        if job is not None and job.index in self._future:
            body["status"] = FUTURE_METRIC_STATUS
        elif job is not None and job.index in self._unreported:
            del body["status"]
        if not self.on:
            return body
        body = self._tidy(body)
        if metric.api_type == "SCALAR" and metric.id.int % 2 == 0:
            body["value"] = None  # the value is in the Metric message only
        return body

    def other(self, body: Json) -> Json:
        """Any other object: metrics data, a report, a build, an experience tag."""
        return self._tidy(body) if self.on else body

    def event(self, body: Json) -> Json:
        """An event: the spec requires every field, so only its timestamps change."""
        if not self.on:
            return body
        for key in ("creationTimestamp", "timestamp"):
            body[key] = _nanoseconds(body[key])
        return body

    def page(self, body: Json) -> Json:
        """A list answer: its last page leaves out the empty nextPageToken."""
        if self.on and not body.get("nextPageToken"):
            body.pop("nextPageToken", None)
        return body

    def job_output(self, output: MetricsOutput) -> MetricsOutput:
        """A job's output with the extra metrics data the quirks list and serve."""
        if not self.on:
            return output
        unnamed = uuid.uuid5(output.owner_id, UNNAMED_DATA)
        message = pb.MetricsData(data_type=pb.DOUBLE_SERIES_DATA_TYPE)  # no name: valid
        message.metrics_data_id.id.data = str(unnamed)
        message.series.doubles.series.extend([1.0, 2.0, 3.0])
        cloud = uuid.uuid5(output.owner_id, POINT_CLOUD_DATA)
        extra = (
            # An empty storage type is left out of the listing, like the empty name.
            StoredData(
                unnamed,
                "",
                "",
                None,
                message.SerializeToString(deterministic=True),
                "application/octet-stream",
            ),
            StoredData(
                cloud,
                POINT_CLOUD_DATA,
                _FUTURE_STORAGE_TYPE,
                "cloud.pcd",
                b"emulated point cloud",
                "application/octet-stream",
            ),
        )
        data = output.data + extra
        return MetricsOutput(
            output.owner_id,
            output.metrics,
            data,
            output.truth,
            {m.id: m for m in output.metrics},
            {d.id: d for d in data},
            output.events,
        )

    # ---- helpers ----

    def _tidy(self, body: Mapping[str, Any]) -> Json:
        """Go's omitempty, and nanosecond timestamps."""
        out: Json = {}
        for key, value in body.items():
            if value is None or value is False or value in ("", [], {}):
                continue
            if isinstance(value, str) and (key.endswith("Timestamp") or key == "updatedAt"):
                value = _nanoseconds(value)
            elif isinstance(value, list):
                value = [self._tidy(v) if isinstance(v, Mapping) else v for v in value]
            out[key] = value
        return out


def _nanoseconds(text: str) -> str:
    """An RFC 3339 UTC time with nine fractional digits, as Go's RFC3339Nano writes it."""
    moment = datetime.fromisoformat(text)
    return f"{moment:%Y-%m-%dT%H:%M:%S}.{moment.microsecond:06d}{_EXTRA_NANOS}Z"
