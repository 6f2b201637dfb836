"""Constructors for metrics data: ``data.doubles("speeds", values, unit="m/s")`` and friends."""

from stook.sdk._data import (
    MetricsData,
    doubles,
    external_file,
    per_category,
    status_like,
    statuses,
    strings,
    timestamps,
    uuids,
)

__all__ = [
    "MetricsData",
    "doubles",
    "external_file",
    "per_category",
    "status_like",
    "statuses",
    "strings",
    "timestamps",
    "uuids",
]
