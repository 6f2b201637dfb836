"""Query values as the writer wants them: numbers, labels, timestamps, JSON."""

from __future__ import annotations

import datetime as dt
import decimal
import math
from typing import Any


def number(value: Any) -> float | None:
    """A query value as a float; None for NULL and for what is not a number."""
    if value is None or isinstance(value, bool):
        return None if value is None else float(value)
    if isinstance(value, int | float | decimal.Decimal):
        result = float(value)
        return None if math.isnan(result) else result
    if isinstance(value, dt.datetime):
        stamp = value if value.tzinfo else value.replace(tzinfo=dt.UTC)
        return stamp.timestamp()
    return None


def label(value: Any) -> str:
    """A value shown as text: a category, a series name, a table cell."""
    if value is None:
        return "NULL"
    if isinstance(value, float) and value.is_integer():
        return str(int(value)) if abs(value) < 1e15 else repr(value)
    return str(value)


def timestamp_ns(value: Any) -> int | None:
    """A state timeline's time: ints are nanoseconds, floats seconds (as in stook.sdk)."""
    if value is None or isinstance(value, bool):
        return None
    if isinstance(value, int):
        return value
    if isinstance(value, float | decimal.Decimal):
        return round(float(value) * 1_000_000_000)
    if isinstance(value, dt.datetime):
        stamp = value if value.tzinfo else value.replace(tzinfo=dt.UTC)
        return round(stamp.timestamp() * 1_000_000_000)
    return None


def plain(value: Any) -> Any:
    """A value JSON can hold (for Liquid templates and Plotly figures)."""
    if value is None or isinstance(value, bool | int | str):
        return value
    if isinstance(value, float):
        return None if math.isnan(value) or math.isinf(value) else value
    if isinstance(value, decimal.Decimal):
        return float(value)
    if isinstance(value, list | tuple):
        return [plain(v) for v in value]
    if isinstance(value, dict):
        return {str(k): plain(v) for k, v in value.items()}
    if isinstance(value, dt.datetime | dt.date):
        return value.isoformat()
    return str(value)
