"""Checks of the arguments the writer's metric methods take.

Each raises a `WriterError` that names the metric, before anything is written, so that
a mistake shows where it is made rather than as a platform refusal of the finished
output. They check what the SDK's types cannot: data kinds and indexes, matching
shapes and counts, UUID and colour spellings.
"""

from __future__ import annotations

import uuid
from collections.abc import Sequence
from typing import Any

from stook.sdk._data import MetricsData
from stook.sdk._enums import MetricStatus, SeriesKind
from stook.sdk._errors import WriterError


def require_kind(
    metric: str, data: MetricsData, kind: SeriesKind, *, index: SeriesKind | None = None
) -> None:
    if data.kind is not kind:
        raise WriterError(
            f"metric {metric!r}: data {data.name!r} holds {data.kind.value} values, "
            f"{kind.value} needed"
        )
    if index is not None and (data.index is None or data.index.kind is not index):
        raise WriterError(
            f"metric {metric!r}: data {data.name!r} must be indexed by a {index.value} series"
        )


def matching_statuses(
    metric: str,
    series: list[MetricsData],
    statuses: Sequence[MetricsData] | None,
    status: MetricStatus,
    make: Any,
) -> list[MetricsData]:
    """The status series of each value series: the given ones, checked, or made by `make`."""
    if statuses is None:
        return [make(s, None, status) for s in series]
    if len(statuses) != len(series):
        raise WriterError(f"metric {metric!r}: give one status series per value series")
    for s, st in zip(series, statuses, strict=True):
        require_kind(metric, st, SeriesKind.STATUS)
        if st.shape() != s.shape() or st.index is not s.index:
            raise WriterError(
                f"metric {metric!r}: status series {st.name!r} must have the shape and index "
                f"of {s.name!r}"
            )
    return list(statuses)


def legend_names(metric: str, names: Sequence[str] | None, series: list[MetricsData]) -> list[str]:
    if names is None:
        return [s.name for s in series]
    if len(names) != len(series):
        raise WriterError(f"metric {metric!r}: give one legend name per series")
    return list(names)


def flat_strings(data: MetricsData) -> list[str]:
    if isinstance(data.values, dict):
        return [str(v) for vs in data.values.values() for v in vs]
    return [str(v) for v in data.values or []]


def canonical_uuid(metric: str, value: object) -> str:
    try:
        return str(value if isinstance(value, uuid.UUID) else uuid.UUID(str(value)))
    except ValueError:
        raise WriterError(f"metric {metric!r}: {value!r} is not a UUID") from None


def check_color(metric: str, color: str) -> None:
    body = color[1:] if color.startswith("#") else ""
    if len(body) not in (6, 8) or any(c not in "0123456789abcdefABCDEF" for c in body):
        raise WriterError(f"metric {metric!r}: colour {color!r} is not #RRGGBB or #RRGGBBAA")
