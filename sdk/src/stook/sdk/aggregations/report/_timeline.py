"""The report's batches in order, and the per-batch reductions its charts share.

`BatchPoint` places a batch on the shared x axis of report charts, by creation time;
`status_in`, `counts` and `first_seen` reduce a batch's job columns (`JobColumns`): which
jobs have a status in a set, and counts per experience, with numpy instead of a loop per
job.
"""

from __future__ import annotations

import uuid
from collections.abc import Collection, Sequence
from dataclasses import dataclass
from datetime import datetime
from typing import TYPE_CHECKING

from stook.sdk import _data
from stook.sdk._data import MetricsData
from stook.sdk._enums import MetricStatus
from stook.sdk.aggregations._columns import JobColumns

if TYPE_CHECKING:
    import numpy as np


@dataclass(frozen=True, slots=True, order=True)
class BatchPoint:
    """A batch on the timeline; ordered by creation time, then ID for ties."""

    created: datetime
    batch_id: uuid.UUID
    name: str


def api_status(text: str) -> MetricStatus:
    """A metric status as the API spells it; statuses the SDK cannot write read as RAW."""
    try:
        return MetricStatus[text]
    except KeyError:
        return MetricStatus.RAW


def days_since(origin: datetime, moments: Sequence[datetime]) -> list[float]:
    return [(m - origin).total_seconds() / 86_400 for m in moments]


def axis(
    label: str, origin: datetime, points: Sequence[BatchPoint]
) -> tuple[MetricsData, MetricsData]:
    """Batch creation times (the index) and days since `origin` (the x values) for `points`."""
    created = [p.created for p in points]
    times = _data.timestamps(f"{label} (batch times)", created)
    x = _data.doubles(f"{label} (days)", days_since(origin, created), unit="days", index=times)
    return times, x


def axis_name(origin: datetime) -> str:
    return f"Days since {origin:%Y-%m-%d %H:%M} UTC"


def status_in(columns: JobColumns, statuses: Collection[str]) -> np.ndarray:
    """Per job: is its conflated status one of `statuses`?"""
    import numpy as np

    table = np.asarray([s in statuses for s in columns.statuses], dtype=bool)
    found: np.ndarray = table[columns.status] if len(table) else np.zeros(len(columns), bool)
    return found


def first_seen(codes: np.ndarray) -> list[int]:
    """The distinct codes in the order they first appear (as a loop over the jobs would
    meet them)."""
    import numpy as np

    distinct, first = np.unique(codes, return_index=True)
    ordered: list[int] = distinct[np.argsort(first)].tolist()
    return ordered


def counts(codes: np.ndarray, size: int) -> list[int]:
    """How many times each code 0..size-1 occurs."""
    import numpy as np

    found: list[int] = np.bincount(codes, minlength=size).tolist()
    return found
