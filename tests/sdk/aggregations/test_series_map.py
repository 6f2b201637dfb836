"""SeriesByName: a job's double series, made into polars only when asked for."""

from __future__ import annotations

import math
import struct

import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk import MetricsDataView, read_metrics_data
from stook.sdk.aggregations import SeriesByName
from tests.sdk.support import bare_data


def doubles(name: str, values: list[float]) -> MetricsDataView:
    d = bare_data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.name = name
    d.series.doubles.series.extend(values)
    return read_metrics_data(d.SerializeToString())


def test_it_reads_like_the_dict_of_the_views_series() -> None:
    views = {"b": doubles("b", [1.0, 2.0]), "a": doubles("a", [float(i) for i in range(100)])}
    series = SeriesByName(views)
    assert list(series) == ["b", "a"]
    assert len(series) == 2
    assert "a" in series
    assert "c" not in series
    assert series.get("c") is None
    for name, view in views.items():
        assert series[name].equals(view.series())
        assert series[name].name == name
    assert series["a"] is series["a"]  # made once
    assert repr(series) == repr({name: view.series() for name, view in views.items()})
    with pytest.raises(KeyError):
        series["c"]


@pytest.mark.parametrize("length", [3, 300])  # below and above the packed-bytes path
def test_values_of_are_the_series_values_bit_for_bit(length: int) -> None:
    values = [[math.nan, -0.0, math.inf, -math.inf, 5e-324][i % 5] * (i + 1) for i in range(length)]
    series = SeriesByName({"v": doubles("v", values)})
    got = series.values_of("v")
    assert got is not None
    assert got.tobytes() == struct.pack(f"<{length}d", *values)
    assert got.tobytes() == series["v"].to_numpy().tobytes()
    assert series.values_of("w") is None


def test_only_plain_double_data_is_taken() -> None:
    per_category = bare_data(pb.DOUBLE_SERIES_DATA_TYPE, is_per_category=True)
    per_category.series_per_category.category_to_series["x"].doubles.series.append(1.0)
    strings = bare_data(pb.STRING_SERIES_DATA_TYPE)
    for msg in (per_category, strings):
        view = read_metrics_data(msg.SerializeToString())
        with pytest.raises(ValueError, match="not a plain double series"):
            SeriesByName({msg.name: view})
