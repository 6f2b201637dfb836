"""Building aggregations from config tables: built-ins, ``module:Class`` and plugins."""

from __future__ import annotations

import importlib.metadata
import uuid
from dataclasses import dataclass, field
from importlib.metadata import EntryPoint
from pathlib import Path
from typing import Any, Self

import pytest

from stook.sdk import MetricsWriter, read_job_metrics
from stook.sdk.aggregations import (
    AggregationConfigError,
    BatchAggregation,
    JobRecord,
    JobStatusCounts,
    MergedHistogram,
    MetricStatusCounts,
    Needs,
    PassRate,
    Scalar,
    ScalarStats,
    WeightedMean,
    _registry,
    build,
    build_all,
    default_batch_aggregations,
)
from stook.sdk.aggregations.report import JobScalarDistributions, ScalarLines

# ---------------------------------------------------------------- a user's own aggregation


@dataclass
class MaxOfScalar(BatchAggregation):
    """The largest value of one scalar across the batch: an example of a user's aggregation."""

    metric: str
    name: str = "Max"
    unit: str = ""

    best: float | None = field(default=None, init=False)

    def needs(self) -> Needs:
        return Needs(scalars=frozenset({self.metric}))

    def update(self, job: JobRecord) -> None:
        x = job.scalars.get(self.metric)
        if x is not None and (self.best is None or x.value > self.best):
            self.best = x.value

    def merge(self, other: Self) -> None:
        if other.best is not None and (self.best is None or other.best > self.best):
            self.best = other.best

    def finish(self, writer: MetricsWriter) -> None:
        if self.best is not None:
            writer.scalar(self.name, self.best, unit=self.unit)


class NotAnAggregation:
    def __init__(self, **options: Any) -> None:
        self.options = options


def not_a_class(**options: Any) -> MaxOfScalar:
    return MaxOfScalar(**options)


HERE = __name__  # "tests.sdk.aggregations.test_registry" under pytest


def job(**scalars: float) -> JobRecord:
    return JobRecord(uuid.uuid4(), "PASSED", scalars={k: Scalar(v) for k, v in scalars.items()})


# ---------------------------------------------------------------- built-ins


def test_build_all_weighted_mean_from_a_table() -> None:
    built = build_all(
        {"weighted_mean": [{"name": "Err", "metric": "err", "weight": "dist", "unit": "m"}]},
        section="batch",
    )
    assert len(built) == 1
    agg = built[0]
    assert isinstance(agg, WeightedMean)
    assert (agg.name, agg.metric, agg.weight, agg.unit) == ("Err", "err", "dist", "m")
    assert agg.needs() == Needs(scalars=frozenset({"err", "dist"}))


def test_build_all_keeps_the_order_of_kinds_and_entries() -> None:
    built = build_all(
        {
            "histogram": [
                {"name": "H1", "data": "speed", "lower": 0, "upper": 10, "buckets": 5},
                {"name": "H2", "data": "accel", "lower": -1.5, "upper": 1.5, "max_values": 10},
            ],
            "scalar_stats": [{"metric": "lat", "stats": ["p99", "count"]}],
            "job_status_counts": [{}],
            "metric_status_counts": [{"name": "MS"}],
            "pass_rate": [{"name": "PR"}],
        },
        section="batch",
    )
    assert [type(a) for a in built] == [
        MergedHistogram,
        MergedHistogram,
        ScalarStats,
        JobStatusCounts,
        MetricStatusCounts,
        PassRate,
    ]
    assert [a.name for a in built] == ["H1", "H2", "lat", "Job statuses", "MS", "PR"]
    h2 = built[1]
    assert isinstance(h2, MergedHistogram)
    assert (h2.data, h2.lower, h2.upper, h2.buckets, h2.max_values) == ("accel", -1.5, 1.5, 20, 10)
    stats = built[2]
    assert isinstance(stats, ScalarStats)
    assert list(stats.stats) == ["p99", "count"]


def test_build_all_of_nothing_is_empty() -> None:
    assert build_all({}, section="batch") == []
    assert build_all({"pass_rate": []}, section="batch") == []


def test_unknown_kind_is_named() -> None:
    with pytest.raises(AggregationConfigError) as info:
        build_all({"weighted_maen": [{"name": "x", "metric": "y"}]}, section="batch")
    message = str(info.value)
    assert message.startswith(
        "[[batch.weighted_maen]] #1: unknown aggregation kind 'weighted_maen'"
    )
    for known in ("weighted_mean", "histogram", "scalar_stats", "pass_rate", "custom"):
        assert known in message


def test_unknown_option_names_the_table_and_the_option() -> None:
    with pytest.raises(AggregationConfigError) as info:
        build_all(
            {
                "weighted_mean": [
                    {"name": "ok", "metric": "x"},
                    {"name": "bad", "metric": "x", "colour": "red"},
                ]
            },
            section="batch",
        )
    message = str(info.value)
    assert message.startswith("[[batch.weighted_mean]] #2: ")
    assert "colour" in message


def test_missing_option_names_the_table() -> None:
    with pytest.raises(AggregationConfigError, match=r"^\[\[batch\.histogram\]\] #1: .*'upper'"):
        build_all(
            {"histogram": [{"name": "H", "data": "d", "lower": 0}]},
            section="batch",
        )


def test_report_sections_know_their_own_kinds() -> None:
    built = build_all({"scalar_lines": [{"window": 5}]}, section="report")
    assert [type(a).__name__ for a in built] == ["ScalarLines"]
    with pytest.raises(AggregationConfigError, match=r"unknown aggregation kind 'histogram'"):
        build_all(
            {"histogram": [{"name": "H", "data": "d", "lower": 0, "upper": 1}]}, section="report"
        )


@pytest.mark.parametrize(
    ("kind", "options", "needle"),
    [
        ("histogram", {"name": "H", "data": "d", "lower": 1, "upper": 0}, "lower < upper"),
        ("histogram", {"name": "H", "data": "d", "lower": 0, "upper": 1, "buckets": 0}, "count"),
        (
            "histogram",
            {"name": "H", "data": "d", "lower": 0, "upper": 1, "max_values": 0},
            "max_values must be at least 1",
        ),
        ("scalar_stats", {"metric": "x", "stats": ["mean", "median"]}, "'median'"),
    ],
)
def test_bad_option_values_name_the_table(kind: str, options: dict[str, Any], needle: str) -> None:
    with pytest.raises(AggregationConfigError) as info:
        build(kind, options, where=f"[[batch.{kind}]] #3")
    assert str(info.value).startswith(f"[[batch.{kind}]] #3: ")
    assert needle in str(info.value)


def test_a_table_instead_of_an_array_of_tables() -> None:
    with pytest.raises(AggregationConfigError) as info:
        build_all({"histogram": {"name": "H", "data": "d"}}, section="batch")  # type: ignore[dict-item]
    assert str(info.value) == (
        "[batch.histogram] must be an array of tables: write [[batch.histogram]]"
    )


def test_build_does_not_consume_the_callers_options() -> None:
    options = {"class": f"{HERE}:MaxOfScalar", "metric": "x"}
    build("custom", options, where="w")
    assert options == {"class": f"{HERE}:MaxOfScalar", "metric": "x"}


# ---------------------------------------------------------------- custom classes


def test_custom_class_is_loaded_and_works() -> None:
    built = build_all(
        {"custom": [{"class": f"{HERE}:MaxOfScalar", "metric": "speed", "name": "Top speed"}]},
        section="batch",
    )
    assert len(built) == 1
    agg = built[0]
    assert type(agg) is MaxOfScalar
    assert (agg.metric, agg.name) == ("speed", "Top speed")
    assert agg.needs().scalars == {"speed"}

    # It folds, merges and writes like a built-in.
    other = agg.fresh()
    for v in (3.0, 9.5):
        agg.update(job(speed=v))
    other.update(job(speed=12.25))
    other.update(job(accel=99.0))
    agg.merge(other)
    writer = MetricsWriter(uuid.uuid4(), deterministic=True)
    agg.finish(writer)
    view = read_job_metrics(writer.serialize())
    assert [(m.name, m.value) for m in view.metrics] == [("Top speed", 12.25)]


@pytest.mark.parametrize(
    ("options", "needle"),
    [
        pytest.param(
            {"metric": "x"}, "a custom aggregation needs class = 'module:Class'", id="none"
        ),
        pytest.param({"class": 5}, "a custom aggregation needs class", id="not-a-string"),
        pytest.param(
            {"class": f"{HERE}.MaxOfScalar"},
            f"class '{HERE}.MaxOfScalar' is not 'module:Class'",
            id="no-colon",
        ),
        pytest.param({"class": ":MaxOfScalar"}, "is not 'module:Class'", id="no-module"),
        pytest.param(
            {"class": f"{HERE}:NotAnAggregation"},
            f"'{HERE}:NotAnAggregation' is not a stook Aggregation class",
            id="other-class",
        ),
        pytest.param(
            {"class": f"{HERE}:not_a_class"},
            f"'{HERE}:not_a_class' is not a stook Aggregation class",
            id="function",
        ),
        pytest.param(
            {"class": "stook.sdk.aggregations:Aggregation"},
            "Can't instantiate abstract class",
            id="abstract-base",
        ),
        pytest.param(
            {"class": "no_such_module_for_stook_tests:Thing"},
            "cannot import 'no_such_module_for_stook_tests:Thing' (No module named",
            id="no-module-found",
        ),
        pytest.param(
            {"class": f"{HERE}:Missing"},
            f"cannot import '{HERE}:Missing' (module '{HERE}' has no attribute 'Missing')",
            id="no-attribute",
        ),
        pytest.param(
            {"class": f"{HERE}:MaxOfScalar", "metric": "x", "colour": "red"},
            "colour",
            id="bad-option",
        ),
        pytest.param({"class": f"{HERE}:MaxOfScalar"}, "'metric'", id="missing-option"),
    ],
)
def test_custom_class_errors(options: dict[str, Any], needle: str) -> None:
    with pytest.raises(AggregationConfigError) as info:
        build_all(
            {"custom": [{"class": f"{HERE}:MaxOfScalar", "metric": "a"}, options]},
            section="batch",
        )
    message = str(info.value)
    assert message.startswith("[[batch.custom]] #2: ")
    assert needle in message


def test_a_failing_import_is_reported_not_raised(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "stook_test_broken_plugin.py").write_text("import no_such_dependency_xyz\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(AggregationConfigError, match=r"cannot import .*no_such_dependency_xyz"):
        build("custom", {"class": "stook_test_broken_plugin:Agg"}, where="[[batch.custom]] #1")


# ---------------------------------------------------------------- entry-point plugins


def _fake_entry_points(*eps: EntryPoint) -> Any:
    def entry_points(*, group: str) -> list[EntryPoint]:
        assert group == "stook.aggregations"
        return list(eps)

    return entry_points


def test_plugins_from_entry_points(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(
        importlib.metadata,
        "entry_points",
        _fake_entry_points(
            EntryPoint("max_of", f"{HERE}:MaxOfScalar", "stook.aggregations"),
            EntryPoint("pass_rate", f"{HERE}:MaxOfScalar", "stook.aggregations"),
            EntryPoint("broken", f"{HERE}:NotAnAggregation", "stook.aggregations"),
        ),
    )
    kinds = _registry.kinds()
    assert kinds["max_of"] == f"{HERE}:MaxOfScalar"
    assert kinds["pass_rate"] is PassRate  # a built-in is not shadowed by a plugin

    built = build_all({"max_of": [{"metric": "x"}], "pass_rate": [{}]}, section="batch")
    assert [type(a) for a in built] == [MaxOfScalar, PassRate]

    with pytest.raises(AggregationConfigError, match=r"^\[\[batch\.broken\]\] #1: .*not a stook"):
        build_all({"broken": [{}]}, section="batch")
    with pytest.raises(AggregationConfigError) as info:
        build_all({"nope": [{}]}, section="batch")
    assert "broken" in str(info.value)
    assert "max_of" in str(info.value)


def test_a_built_in_kind_is_built_without_listing_the_plugins(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # Listing the installed plugins reads every distribution's metadata (start-up time).
    def no_scan(*, group: str) -> list[EntryPoint]:
        raise AssertionError(f"plugins listed ({group}) for a built-in kind")

    monkeypatch.setattr(importlib.metadata, "entry_points", no_scan)
    built = build_all({"pass_rate": [{}]}, section="batch")
    assert [type(a) for a in built] == [PassRate]
    with pytest.raises(AssertionError, match="plugins listed"):
        build_all({"not_built_in": [{}]}, section="batch")


def test_needs_say_which_scalars_are_read() -> None:
    """Scalars listed without a value are downloaded only for aggregations that read them."""
    named = Needs(scalars=frozenset({"a"}))
    assert named.wants_scalar("a")
    assert not named.wants_scalar("b")
    assert (named | Needs(every_scalar=True)).wants_scalar("b")
    defaults = Needs()
    for aggregation in default_batch_aggregations():
        defaults = defaults | aggregation.needs()
    assert defaults.every_scalar  # "N (mean)" and "N (distribution)" of every scalar
    assert ScalarLines().needs().every_scalar
    assert JobScalarDistributions().needs().every_scalar
    chosen = JobScalarDistributions(metrics=["x"]).needs()
    assert (chosen.every_scalar, chosen.scalars) == (False, frozenset({"x"}))
