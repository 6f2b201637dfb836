"""Test-mode metrics functions that the end-to-end tests name in stook.toml."""

from __future__ import annotations

import asyncio
import contextlib
import time
from dataclasses import dataclass, field
from pathlib import Path

from stook.proto import metrics_pb2 as pb
from stook.sdk import MetricsWriter
from stook.sdk.aggregations import BatchAggregation, JobRecord

ASYNC_VALUE = 42.5


def unset_status(experience_dir: Path, logs_dir: Path, writer: MetricsWriter) -> None:
    """Reaches past the writer's checks through the public `MetricHandle.proto`: the
    output then breaks a platform rule, which only the final validation can catch."""
    writer.scalar("Lane keeping score", 0.93)
    writer.scalar("Broken scalar", 1.0).proto.status = pb.NO_METRIC_STATUS


def raises(experience_dir: Path, logs_dir: Path, writer: MetricsWriter) -> None:
    writer.scalar("Written before the bug", 1.0)
    _lane_model_step(experience_dir)


def _lane_model_step(experience_dir: Path) -> None:
    raise RuntimeError(f"lane model diverged on {experience_dir.name}")


async def async_metrics(experience_dir: Path, logs_dir: Path, writer: MetricsWriter) -> None:
    await asyncio.sleep(0)
    log_lines = (logs_dir / "run.log").read_text().splitlines()
    writer.scalar("Log lines", float(len(log_lines)))
    writer.scalar("Async value", ASYNC_VALUE, unit="m")


@dataclass
class FailsAfterJobs(BatchAggregation):
    """A batch aggregation with a bug that shows only after `after` jobs: it raises
    mid-fetch, inside one of the fetch's workers."""

    name: str = "Fails after jobs"
    after: int = 300
    seen: int = field(default=0, init=False)

    def update(self, record: JobRecord) -> None:
        self.seen += 1
        if self.seen > self.after:
            raise RuntimeError(f"aggregation bug on job {record.job_id}")

    def merge(self, other: FailsAfterJobs) -> None:
        self.seen += other.seen

    def finish(self, writer: MetricsWriter) -> None:
        writer.scalar(self.name, float(self.seen))


@dataclass
class StuckFinish(BatchAggregation):
    """A batch aggregation whose `finish` never returns and swallows every exception,
    signals' included; it touches `marker` when it starts."""

    marker: str
    name: str = "Stuck finish"

    def update(self, record: JobRecord) -> None:
        pass

    def merge(self, other: StuckFinish) -> None:
        pass

    def finish(self, writer: MetricsWriter) -> None:
        Path(self.marker).touch()
        while True:  # the bug this aggregation stands for
            with contextlib.suppress(BaseException):
                time.sleep(0.05)
