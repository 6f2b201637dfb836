"""Aggregation tables are checked like [fetch]: an unknown key lists the known ones, a missing
key is named, built-in and custom classes alike; never a Python ``__init__()`` message."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import pytest

from stook.sdk import MetricsWriter
from stook.sdk.aggregations import AggregationConfigError, BatchAggregation, JobRecord, build_all

HERE = __name__


@dataclass
class CountJobs(BatchAggregation):
    name: str
    minimum: int = 0

    def update(self, job: JobRecord) -> None:
        pass

    def merge(self, other: CountJobs) -> None:
        pass

    def finish(self, writer: MetricsWriter) -> None:
        pass


class PlainInit(BatchAggregation):
    """A custom class that is not a dataclass: its __init__ signature is what counts."""

    def __init__(self, metric: str, *, scale: float = 1.0) -> None:
        self.metric = metric
        self.scale = scale

    def update(self, job: JobRecord) -> None:
        pass

    def merge(self, other: PlainInit) -> None:
        pass

    def finish(self, writer: MetricsWriter) -> None:
        pass


class TakesAnything(PlainInit):
    def __init__(self, metric: str, **options: Any) -> None:
        super().__init__(metric)
        self.options = options


def build_error(kind: str, table: dict[str, Any]) -> str:
    with pytest.raises(AggregationConfigError) as info:
        build_all({kind: [table]}, section="batch")
    message = str(info.value)
    assert "__init__" not in message
    assert "keyword argument" not in message
    return message


def test_an_unknown_key_of_a_builtin_lists_the_known_ones() -> None:
    table = {"name": "H", "data": "d", "lower": 0, "upper": 1, "bins": 4}
    assert build_error("histogram", table) == (
        "[[batch.histogram]] #1: unknown key 'bins' "
        "(known: buckets, data, lower, max_values, metric, name, upper, x_axis_name)"
    )


def test_missing_keys_of_a_builtin_are_named() -> None:
    assert build_error("histogram", {"name": "H", "data": "d"}) == (
        "[[batch.histogram]] #1: missing keys 'lower', 'upper' "
        "(the histogram's bounds, needed with 'data')"
    )
    assert build_error("weighted_mean", {"name": "W"}) == (
        "[[batch.weighted_mean]] #1: missing key 'metric'"
    )


def test_a_report_table_is_checked_the_same_way() -> None:
    with pytest.raises(AggregationConfigError) as info:
        build_all({"scalar_lines": [{"windw": 5}]}, section="report")
    assert str(info.value).startswith("[[report.scalar_lines]] #1: unknown key 'windw' (known: ")


def test_a_custom_dataclass_lists_its_keys_and_class() -> None:
    table = {"class": f"{HERE}:CountJobs", "name": "n", "minimun": 2}
    assert build_error("custom", table) == (
        "[[batch.custom]] #1: unknown key 'minimun' (known: class, minimum, name)"
    )
    assert build_error("custom", {"class": f"{HERE}:CountJobs"}) == (
        "[[batch.custom]] #1: missing key 'name'"
    )


def test_a_custom_plain_class_is_checked_by_its_signature() -> None:
    assert build_error("custom", {"class": f"{HERE}:PlainInit", "metric": "m", "scal": 2}) == (
        "[[batch.custom]] #1: unknown key 'scal' (known: class, metric, scale)"
    )
    assert build_error("custom", {"class": f"{HERE}:PlainInit"}) == (
        "[[batch.custom]] #1: missing key 'metric'"
    )
    (built,) = build_all(
        {"custom": [{"class": f"{HERE}:PlainInit", "metric": "m", "scale": 2.0}]}, section="batch"
    )
    assert isinstance(built, PlainInit)
    assert built.scale == 2.0


def test_a_class_that_takes_any_key_gets_them() -> None:
    (built,) = build_all(
        {"custom": [{"class": f"{HERE}:TakesAnything", "metric": "m", "colour": "red"}]},
        section="batch",
    )
    assert isinstance(built, TakesAnything)
    assert built.options == {"colour": "red"}
