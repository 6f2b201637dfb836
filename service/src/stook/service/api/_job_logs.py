"""A job's log, as `GET /projects/{p}/batches/{b}/jobs/{j}/logs` lists it (the spec's `jobLog`).

Config-defined metrics read what a test emitted from its job's EMISSIONS_LOG; the listing
hands out each log's presigned `logOutputLocation`, downloaded by the storage client.
"""

from __future__ import annotations

import enum
import uuid
from collections.abc import Mapping
from dataclasses import dataclass
from datetime import datetime
from typing import Any, Final, Self

from stook.service.api._fields import Fields

__all__ = ["EMISSIONS_FILE", "ExecutionStep", "JobLog", "LogType"]

#: The name the platform gives a test's emissions file, and its log.
EMISSIONS_FILE: Final = "emissions.resim.jsonl"


class LogType(enum.StrEnum):
    """The spec's `logType`."""

    OTHER_LOG = "OTHER_LOG"
    METRICS_OUTPUT_LOG = "METRICS_OUTPUT_LOG"
    CONTAINER_LOG = "CONTAINER_LOG"
    EXECUTION_LOG = "EXECUTION_LOG"
    MCAP_LOG = "MCAP_LOG"
    MP4_LOG = "MP4_LOG"
    ARCHIVE_LOG = "ARCHIVE_LOG"
    FOXGLOVE_MCAP_LOG = "FOXGLOVE_MCAP_LOG"
    RERUN_IO_LOG = "RERUN_IO_LOG"
    ERROR_LOG = "ERROR_LOG"
    SERVICE_LOG = "SERVICE_LOG"
    EMISSIONS_LOG = "EMISSIONS_LOG"
    SYSTEM_LOG = "SYSTEM_LOG"


class ExecutionStep(enum.StrEnum):
    """The spec's `executionStep`: which step of the job wrote the log."""

    EXPERIENCE = "EXPERIENCE"
    METRICS = "METRICS"
    BATCH_METRICS = "BATCH_METRICS"
    REPORT = "REPORT"


@dataclass(frozen=True, slots=True)
class JobLog:
    """One log of a job (the spec's `jobLog`). Only its ID is required, as with the other
    objects (see _models); a log without `logOutputLocation` cannot be downloaded. Unknown
    log types and steps are kept as their raw strings."""

    log_id: uuid.UUID
    file_name: str = ""
    log_type: LogType | str | None = None
    log_output_location: str | None = None
    file_size: int | None = None
    checksum: str | None = None
    creation_timestamp: datetime | None = None
    execution_step: ExecutionStep | str | None = None
    file_path: str = ""
    job_id: uuid.UUID | None = None

    @classmethod
    def from_json(cls, data: Mapping[str, Any]) -> Self:
        f = Fields("JobLog", data, "logID")
        return cls(
            log_id=f.id("logID"),
            file_name=f.opt_string("fileName") or "",
            log_type=f.opt_choice("logType", LogType),
            log_output_location=f.opt_string("logOutputLocation"),
            file_size=f.opt_integer("fileSize"),
            checksum=f.opt_string("checksum"),
            creation_timestamp=f.opt_timestamp("creationTimestamp"),
            execution_step=f.opt_choice("executionStep", ExecutionStep),
            file_path=f.opt_string("filePath") or "",
            job_id=f.opt_id("jobID"),
        )
