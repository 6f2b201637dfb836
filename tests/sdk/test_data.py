"""The metrics-data constructors (`stook.sdk.data`): what they refuse, and how."""

from __future__ import annotations

from datetime import datetime
from typing import cast

import polars as pl
import pytest

from stook.sdk import SeriesKind, WriterError, data
from tests.sdk.support import writer_error


def test_data_constructor_errors() -> None:
    with writer_error("metrics data needs a non-empty name"):
        data.doubles("", [1.0])
    with writer_error("metrics data needs a non-empty name"):
        data.external_file("", "a.png")
    with writer_error("metrics data 'f': an external file needs a path"):
        data.external_file("f", "")
    with writer_error("metrics data 'x': its shape 2 differs from its index 'i' shape 3"):
        data.doubles("x", [1.0, 2.0], index=data.strings("i", ["a", "b", "c"]))
    with writer_error(
        "metrics data 'x': its shape {'a': 1} differs from its index 'i' shape {'a': 2}"
    ):
        data.per_category(
            "x",
            SeriesKind.DOUBLE,
            {"a": [1.0]},
            index=data.per_category("i", SeriesKind.STRING, {"a": ["p", "q"]}),
        )
    with writer_error("metrics data 'x': its shape {'a': 1} differs from its index 'i' shape 1"):
        data.per_category("x", SeriesKind.DOUBLE, {"a": [1.0]}, index=data.strings("i", ["p"]))
    with writer_error("metrics data 'x': an external file cannot be an index"):
        data.doubles("x", [1.0], index=data.external_file("f", "f.png"))
    with writer_error("metrics data 'x': a per-category series needs a category"):
        data.per_category("x", SeriesKind.DOUBLE, {})
    with writer_error("metrics data 'x': an external file has no series"):
        data.per_category("x", SeriesKind.EXTERNAL_FILE, {"a": ["p.png"]})
    with writer_error("timestamp 2026-01-01T00:00:00 has no time zone; use an aware one"):
        data.timestamps("t", [datetime(2026, 1, 1)])
    with writer_error("timestamp nan is not a finite number of seconds"):
        data.timestamps("t", [float("nan")])
    with writer_error(
        "timestamp True must be an aware datetime, integer nanoseconds or float seconds"
    ):
        data.timestamps("t", [True])
    with writer_error(
        "timestamp '1.5' must be an aware datetime, integer nanoseconds or float seconds"
    ):
        data.timestamps("t", ["1.5"])  # type: ignore[list-item]
    with writer_error("'not-a-uuid' is not a UUID"):
        data.uuids("u", ["not-a-uuid"])
    with writer_error("12 is not a UUID"):
        data.uuids("u", [12])  # type: ignore[list-item]


def test_doubles_refuse_values_that_are_not_numbers() -> None:
    with pytest.raises(WriterError, match=r"metrics data 'x': values must be numbers"):
        data.doubles("x", ["a"])  # type: ignore[list-item]
    with pytest.raises(WriterError, match=r"metrics data 'x': values must be numbers"):
        data.doubles("x", [None])  # type: ignore[list-item]


def test_doubles_refuse_a_polars_series_of_strings_with_writer_error() -> None:
    with pytest.raises(WriterError, match=r"metrics data 'x'"):
        data.doubles("x", pl.Series(["a"]))


def test_statuses_refuse_unknown_values_with_writer_error() -> None:
    with pytest.raises(WriterError, match="statuses"):
        data.statuses("s", [99])  # type: ignore[list-item]


def test_timestamps_are_float_seconds_integer_nanoseconds_or_aware_datetimes() -> None:
    from datetime import UTC

    import numpy as np

    stamp = datetime(2026, 11, 22, 22, 30, 0, 123456, tzinfo=UTC)
    seconds = stamp.timestamp()  # what a robotics log holds: 1795386600.123456
    given = [0.0, 0.1, 12.5, 1_000, stamp, seconds, np.float64(2.25), np.int64(7)]
    values = cast(list[int], data.timestamps("t", given).values)  # type: ignore[arg-type]
    assert values[:5] == [
        0,
        100_000_000,
        12_500_000_000,
        1_000,  # an int is nanoseconds, as it always was
        1_795_386_600_123_456_000,
    ]
    # A present-day float in seconds keeps its microseconds (a float holds no finer).
    assert abs(values[5] - values[4]) < 1_000
    assert values[6:] == [2_250_000_000, 7]  # numpy's floats are seconds, its ints ns
    # From a polars column of seconds, as a log's time column is read.
    assert data.timestamps("t", pl.Series([0.5, 1.5])).values == [500_000_000, 1_500_000_000]
