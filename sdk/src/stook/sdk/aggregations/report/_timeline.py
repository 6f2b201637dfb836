"""The shared x axis of report charts: batches placed by creation time."""

from __future__ import annotations

import uuid
from collections.abc import Sequence
from dataclasses import dataclass
from datetime import datetime

from stook.sdk import _data
from stook.sdk._data import MetricsData
from stook.sdk._enums import MetricStatus


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
