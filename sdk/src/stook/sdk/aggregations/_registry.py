"""Aggregations by name, and the ones every batch and every report gets.

The built-ins, plugins from the `stook.aggregations` (batch) and
`stook.report_aggregations` (report) entry-point groups, and ``module:Class`` references,
built from the config's ``[[batch.<kind>]]`` and ``[[report.<kind>]]`` tables;
`default_batch_aggregations` and `default_report_aggregations` are what a batch and a
report get with or without a config.
"""

from __future__ import annotations

import collections.abc
import dataclasses
import importlib
import inspect
import sys
import types
import typing
from collections.abc import Iterator, Mapping, Sequence
from typing import Any

from stook.sdk._errors import AggregationConfigError
from stook.sdk.aggregations._base import Aggregation
from stook.sdk.aggregations._scalar_stats import ScalarDefaults
from stook.sdk.aggregations._status_counts import JobStatusCounts, MetricStatusCounts, PassRate

ENTRY_POINT_GROUP = "stook.aggregations"
ENTRY_POINT_GROUPS = {"batch": ENTRY_POINT_GROUP, "report": "stook.report_aggregations"}


class BuiltinKinds(Mapping[str, type[Aggregation[Any]]]):
    """Built-in kinds by name, each class imported when first looked up: a batch run
    builds a few of the batch kinds and none of the report ones (~30 ms of imports)."""

    def __init__(self, package: str, classes: Mapping[str, str]) -> None:
        self._package = package
        self._classes = dict(classes)  # kind -> "_module:Class", relative to package

    def __getitem__(self, kind: str) -> type[Aggregation[Any]]:
        module, _, name = self._classes[kind].partition(":")
        cls: type[Aggregation[Any]] = getattr(importlib.import_module(module, self._package), name)
        return cls

    def __iter__(self) -> Iterator[str]:
        return iter(self._classes)

    def __len__(self) -> int:
        return len(self._classes)

    def __contains__(self, kind: object) -> bool:
        return kind in self._classes


BUILTIN = BuiltinKinds(
    "stook.sdk.aggregations",
    {
        "weighted_mean": "._scalar_stats:WeightedMean",
        "histogram": "._histogram:MergedHistogram",
        "scalar_stats": "._scalar_stats:ScalarStats",
        "job_status_counts": "._status_counts:JobStatusCounts",
        "metric_status_counts": "._status_counts:MetricStatusCounts",
        "pass_rate": "._status_counts:PassRate",
        "category_totals": "._job_metrics:CategoryTotals",
        "events": "._status_counts:EventCounts",
        "sweep": "._scalar_stats:ParameterSweep",
        "by_tag": "._scalar_stats:ByExperienceTag",
    },
)
REPORT_BUILTIN = BuiltinKinds(
    "stook.sdk.aggregations.report",
    {
        "scalar_lines": "._lines:ScalarLines",
        "most_failed_experiences": "._experiences:MostFailedExperiences",
        "flaky_experiences": "._experiences:FlakyExperiences",
        "test_status_over_time": "._statuses:TestStatusOverTime",
        "job_metric_status_counts": "._statuses:JobMetricStatusCounts",
        "batch_metric_status_counts": "._statuses:BatchMetricStatusCounts",
        "job_scalar_distributions": "._lines:JobScalarDistributions",
        "change_points": "._change_report:ChangePoints",
        "unstable_experiences": "._experiences:UnstableExperiences",
    },
)
_BUILTIN_BY_SECTION = {"batch": BUILTIN, "report": REPORT_BUILTIN}


def default_batch_aggregations() -> list[Aggregation[Any]]:
    """What every batch gets, with or without a config."""
    return [ScalarDefaults(), JobStatusCounts(), MetricStatusCounts(), PassRate()]


def default_report_aggregations(
    *,
    project_id: str,
    top_n: int = 10,
    regression_window: int = 10,
    regression_threshold: float = 3.5,
    job_metrics: Sequence[str] | None = None,
    change_points: bool = True,
    change_penalty: float = 3.0,
    unstable_experiences: bool = True,
) -> list[Aggregation[Any]]:
    """What every report gets; the arguments are the ``[report]`` settings."""
    # Imported here: `stook.sdk.aggregations`, which every batch run imports, does not
    # import the report's modules.
    from stook.sdk.aggregations.report import (
        BatchMetricStatusCounts,
        ChangePoints,
        FlakyExperiences,
        JobMetricStatusCounts,
        JobScalarDistributions,
        MostFailedExperiences,
        ScalarLines,
        TestStatusOverTime,
        UnstableExperiences,
    )

    aggregations: list[Aggregation[Any]] = [
        ScalarLines(
            window=regression_window,
            threshold=regression_threshold,
            change_points=change_points,
            change_penalty=change_penalty,
        ),
        MostFailedExperiences(top_n=top_n),
        TestStatusOverTime(project_id=project_id),
        JobMetricStatusCounts(),
        BatchMetricStatusCounts(),
        JobScalarDistributions(metrics=job_metrics),
        FlakyExperiences(top_n=top_n),
    ]
    if change_points:
        aggregations.append(ChangePoints(penalty=change_penalty, top_n=top_n))
    if unstable_experiences:
        aggregations.append(UnstableExperiences(top_n=top_n, metrics=job_metrics))
    return aggregations


def load_class(reference: str, *, where: str) -> type[Aggregation[Any]]:
    """Import ``package.module:Class`` and check that it is an Aggregation[Any]."""
    module_name, _, attr = reference.partition(":")
    if not module_name or not attr:
        raise AggregationConfigError(f"{where}: class {reference!r} is not 'module:Class'")
    try:
        obj = getattr(importlib.import_module(module_name), attr)
    except (ImportError, AttributeError) as exc:
        raise AggregationConfigError(f"{where}: cannot import {reference!r} ({exc})") from None
    if not (isinstance(obj, type) and issubclass(obj, Aggregation)):
        raise AggregationConfigError(f"{where}: {reference!r} is not a stook Aggregation class")
    return obj


def kinds(section: str = "batch") -> dict[str, type[Aggregation[Any]] | str]:
    """Every aggregation kind a config section may name: built-ins and installed plugins."""
    # Imported here: importlib.metadata costs ~20 ms of every start-up, and only a
    # kind that is not built in is looked for among the plugins.
    from importlib.metadata import entry_points

    found: dict[str, type[Aggregation[Any]] | str] = dict(_BUILTIN_BY_SECTION[section])
    for ep in entry_points(group=ENTRY_POINT_GROUPS[section]):
        found.setdefault(ep.name, ep.value)
    return found


def build(
    kind: str, options: Mapping[str, Any], *, where: str, section: str = "batch"
) -> Aggregation[Any]:
    """One aggregation from a config table, e.g. kind 'weighted_mean' and its keys."""
    options = dict(options)
    if kind == "custom":
        reference = options.pop("class", None)
        if not isinstance(reference, str):
            raise AggregationConfigError(
                f"{where}: a custom aggregation needs class = 'module:Class'"
            )
        cls = load_class(reference, where=where)
    elif kind in _BUILTIN_BY_SECTION[section]:
        # A built-in wins over a plugin of the same name (see kinds), so the installed
        # plugins need not be listed for one: that scan costs ~2 ms per table, at start-up.
        cls = _BUILTIN_BY_SECTION[section][kind]
    else:
        known = kinds(section)
        if kind not in known:
            raise AggregationConfigError(
                f"{where}: unknown aggregation kind {kind!r} "
                f"(known: {', '.join(sorted(known))}, custom)"
            )
        found = known[kind]
        cls = found if isinstance(found, type) else load_class(found, where=where)
    _check_option_names(cls, options, where, extra=("class",) if kind == "custom" else ())
    _check_option_types(cls, options, where)
    try:
        return cls(**options)
    except TypeError as exc:
        raise AggregationConfigError(f"{where}: {exc}") from None
    except ValueError as exc:
        raise AggregationConfigError(f"{where}: {exc}") from None


_SIMPLE: dict[Any, tuple[type, ...]] = {
    str: (str,),
    int: (int,),
    float: (int, float),
    bool: (bool,),
}


def _accepts(hint: Any, value: Any) -> bool | None:
    """Whether a TOML value fits a field annotation; None when the annotation is not simple."""
    if hint in _SIMPLE:
        if isinstance(value, bool) and hint is not bool:
            return False
        return isinstance(value, _SIMPLE[hint])
    origin, args = typing.get_origin(hint), typing.get_args(hint)
    if origin in (types.UnionType, typing.Union):
        verdicts = [v for a in args if (v := _accepts(a, value)) is not None or a is type(None)]
        if value is None and type(None) in args:
            return True
        return any(bool(v) for v in verdicts) if verdicts else None
    if origin in (list, tuple, collections.abc.Sequence) and args:
        if not isinstance(value, list):
            return False
        inner = [_accepts(args[0], item) for item in value]
        return None if any(v is None for v in inner) else all(inner)
    return None


def _check_option_names(
    cls: type[Aggregation[Any]], options: Mapping[str, Any], where: str, *, extra: Sequence[str]
) -> None:
    """An unknown key lists the known ones and a missing one is named, as in ``[fetch]``,
    rather than surfacing as ``__init__() got an unexpected keyword argument``."""
    try:
        parameters = inspect.signature(cls).parameters.values()
    except (TypeError, ValueError):
        return  # no signature to read: leave the check to the class
    if any(p.kind is inspect.Parameter.VAR_KEYWORD for p in parameters):
        return  # takes any key
    by_keyword = [
        p
        for p in parameters
        if p.kind in (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    ]
    known = {p.name for p in by_keyword}
    unknown = sorted(set(options) - known)
    if unknown:
        listed = ", ".join(sorted(known | set(extra))) or "none"
        raise AggregationConfigError(f"{where}: unknown key {unknown[0]!r} (known: {listed})")
    missing = [
        p.name for p in by_keyword if p.default is inspect.Parameter.empty and p.name not in options
    ]
    if missing:
        names = ", ".join(repr(name) for name in missing)
        raise AggregationConfigError(
            f"{where}: missing key{'s' if len(missing) > 1 else ''} {names}"
        )


def _check_option_types(
    cls: type[Aggregation[Any]], options: Mapping[str, Any], where: str
) -> None:
    """A TOML value of the wrong type is a config error now, not a crash after the fetch."""
    if not dataclasses.is_dataclass(cls):
        return
    namespace = vars(sys.modules[cls.__module__])
    for field in dataclasses.fields(cls):
        if not field.init or field.name not in options:
            continue
        hint: Any = field.type
        if isinstance(hint, str):
            try:
                hint = eval(hint, namespace)  # the class's own annotation text
            except Exception:
                continue  # not a simple annotation: leave the check to the class
        value = options[field.name]
        if _accepts(hint, value) is False:
            raise AggregationConfigError(
                f"{where}: option {field.name!r} cannot be {value!r} (expected {_describe(hint)})"
            )


def _describe(hint: Any) -> str:
    return getattr(hint, "__name__", None) or str(hint).replace("typing.", "")


def build_all(
    tables: Mapping[str, Sequence[Mapping[str, Any]]], *, section: str
) -> list[Aggregation[Any]]:
    """Every aggregation of a config section such as ``batch``: one per array-of-tables entry."""
    built: list[Aggregation[Any]] = []
    for kind, entries in tables.items():
        if not isinstance(entries, list):
            raise AggregationConfigError(
                f"[{section}.{kind}] must be an array of tables: write [[{section}.{kind}]]"
            )
        for i, options in enumerate(entries):
            where = f"[[{section}.{kind}]] #{i + 1}"
            built.append(build(kind, options, where=where, section=section))
    return built
