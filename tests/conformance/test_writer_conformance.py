"""Whatever legal sequence of calls drives the MetricsWriter, ReSim accepts the output.

A hypothesis program picks metric types, data kinds, lengths, per-category shapes,
indexing, statuses, importance, tags and events at random, calls the writer, and
checks the bytes against stook's validator, ReSim's validator and ReSim's classes
(which must parse and re-serialize them byte for byte).
"""

from __future__ import annotations

import itertools
import json
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import UTC, datetime, timedelta
from pathlib import Path
from typing import Any

import resim.metrics.proto.metrics_pb2 as rp
from hypothesis import given
from hypothesis import strategies as st
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.sdk import (
    MetricHandle,
    MetricImportance,
    MetricsData,
    MetricStatus,
    MetricsWriter,
    MetricType,
    SeriesKind,
    data,
    find_problems,
    read_job_metrics,
)
from stook.sdk.example import every_metric_type
from tests.hypothesis_profiles import examples

Shape = int | dict[str, int]

_STATUSES = st.sampled_from(list(MetricStatus))
_IMPORTANCES = st.sampled_from(list(MetricImportance))
_WORDS = st.sampled_from(["idle", "drive", "stop", "x y", "ü", "a"])
_FLOATS = st.floats(allow_nan=True, allow_infinity=True)
_FINITE = st.floats(min_value=-1e9, max_value=1e9, allow_nan=False)
_EPOCH = datetime(1970, 1, 1, tzinfo=UTC)
_TIMESTAMPS = st.one_of(
    st.integers(0, 4 * 10**18),
    st.datetimes(
        min_value=datetime(1970, 1, 2),
        max_value=datetime(2100, 1, 1),
        timezones=st.just(UTC),
    ),
)
_SERIES_KINDS = [k for k in SeriesKind if k is not SeriesKind.EXTERNAL_FILE]
_COLORS = st.from_regex(r"\A#([0-9a-fA-F]{2}){3,4}\Z")


@dataclass
class Program:
    """Draws one legal sequence of writer calls and makes them."""

    draw: Callable[[st.SearchStrategy[Any]], Any]
    writer: MetricsWriter
    counter: int = 0
    made: list[MetricType] = field(default_factory=list)
    event_metrics: list[MetricHandle] = field(default_factory=list)
    pool: dict[str, list[MetricsData]] = field(default_factory=dict)

    def name(self, prefix: str) -> str:
        self.counter += 1
        return f"{prefix} {self.counter}"

    def shape(self, *, categories: bool = True) -> Shape:
        if categories and self.draw(st.booleans()):
            cats = self.draw(st.lists(_WORDS, min_size=1, max_size=3, unique=True))
            return {c: self.draw(st.integers(1, 3)) for c in cats}
        return int(self.draw(st.integers(1, 5)))

    def elements(self, kind: SeriesKind, n: int, words: Any = _WORDS) -> list[Any]:
        element: st.SearchStrategy[Any] = {
            SeriesKind.DOUBLE: _FLOATS,
            SeriesKind.TIMESTAMP: _TIMESTAMPS,
            SeriesKind.UUID: st.uuids().map(
                lambda u: self.draw(st.sampled_from([u, str(u), str(u).upper()]))
            ),
            SeriesKind.STRING: words,
            SeriesKind.STATUS: _STATUSES,
        }[kind]
        return list(self.draw(st.lists(element, min_size=n, max_size=n)))

    def series(
        self,
        kind: SeriesKind,
        shape: Shape,
        *,
        index: MetricsData | None = None,
        prefix: str = "data",
        words: Any = _WORDS,
    ) -> MetricsData:
        name = self.name(f"{prefix} {kind.value}")
        unit = self.draw(st.sampled_from(["", "m", "m/s"]))
        if isinstance(shape, dict):
            values = {c: self.elements(kind, n, words) for c, n in shape.items()}
            return data.per_category(name, kind, values, unit=unit, index=index)
        plain = self.elements(kind, shape, words)
        constructors: dict[SeriesKind, Callable[..., MetricsData]] = {
            SeriesKind.DOUBLE: data.doubles,
            SeriesKind.TIMESTAMP: data.timestamps,
            SeriesKind.UUID: data.uuids,
            SeriesKind.STRING: data.strings,
            SeriesKind.STATUS: data.statuses,
        }
        return constructors[kind](name, plain, unit=unit, index=index)

    def maybe_index(
        self, shape: Shape, kinds: list[SeriesKind | None], *, chain: bool = True
    ) -> MetricsData | None:
        kind = self.draw(st.sampled_from(kinds))
        if kind is None:
            return None
        below = None
        if chain and self.draw(st.integers(0, 4)) == 0:
            # An index that is itself indexed: a chain of two.
            below = self.series(SeriesKind.STRING, shape, prefix="root")
        return self.series(kind, shape, index=below, prefix="index")

    def statuses_for(self, values: MetricsData) -> MetricsData | None:
        if self.draw(st.booleans()):
            return None
        return self.series(
            SeriesKind.STATUS,
            values.shape(),
            index=values.index,
            prefix="statuses",
        )

    def options(self) -> dict[str, Any]:
        opts: dict[str, Any] = {}
        if self.draw(st.booleans()):
            opts["status"] = self.draw(_STATUSES)
        if self.draw(st.booleans()):
            opts["importance"] = self.draw(_IMPORTANCES)
        if self.draw(st.booleans()):
            opts["description"] = self.draw(st.text(max_size=8))
        if self.draw(st.booleans()):
            opts["blocking"] = self.draw(st.booleans())
        return opts

    def decorate(self, handle: MetricHandle) -> None:
        for _ in range(self.draw(st.integers(0, 2))):
            handle.tag(self.draw(_WORDS), self.draw(_WORDS))
        if self.draw(st.booleans()):
            handle.display(self.draw(st.booleans()))
        if self.draw(st.booleans()):
            handle.order(self.draw(_FINITE))
        if self.draw(st.booleans()):
            handle.importance(self.draw(_IMPORTANCES))
        if self.draw(st.integers(0, 3)) == 0:
            handle.status(self.draw(_STATUSES))

    # ---- one method per metric type

    def scalar(self, name: str, opts: dict[str, Any]) -> MetricHandle:
        limits = {}
        if self.draw(st.booleans()):
            limits["fails_above"] = self.draw(_FINITE)
        if self.draw(st.booleans()):
            limits["fails_below"] = self.draw(_FINITE)
        unit = self.draw(st.sampled_from([None, "m", "s"]))
        value = self.draw(st.floats(allow_nan=False))
        return self.writer.scalar(name, value, unit=unit, **limits, **opts)

    def pooled_doubles(self, kinds: list[SeriesKind | None]) -> MetricsData:
        """A new double series, or one an earlier metric used (shared data)."""
        pool = [d for d in self.pool.get("doubles", []) if (d.index and d.index.kind) in kinds]
        if pool and self.draw(st.booleans()):
            return self.draw(st.sampled_from(pool))  # type: ignore[no-any-return]
        shape = self.shape()
        values = self.series(SeriesKind.DOUBLE, shape, index=self.maybe_index(shape, kinds))
        self.pool.setdefault("doubles", []).append(values)
        return values

    def double_summary(self, name: str, opts: dict[str, Any]) -> MetricHandle:
        values = self.pooled_doubles(
            [None, SeriesKind.TIMESTAMP, SeriesKind.UUID, SeriesKind.STRING]
        )
        index = values.index
        at: Any = None
        choice = self.draw(st.integers(0, 2))
        if choice == 1 and index is not None:
            flat = (
                [v for vs in index.values.values() for v in vs]
                if isinstance(index.values, dict)
                else list(index.values or [])
            )
            at = self.draw(st.sampled_from(flat))
        elif choice == 2 and (index is None or index.kind is not SeriesKind.TIMESTAMP):
            at = self.draw(st.integers(0, 3))
        failure = self.draw(st.one_of(st.none(), st.tuples(_opt_float(), _opt_float())))
        return self.writer.double_summary(
            name,
            values,
            index=at,
            statuses=self.statuses_for(values),
            failure=failure,
            **opts,
        )

    def timed(self, count: int, kind: SeriesKind) -> list[MetricsData]:
        shape = self.shape()
        shared = self.series(SeriesKind.TIMESTAMP, shape, prefix="time")
        out = []
        for _ in range(count):
            index = shared if self.draw(st.booleans()) else None
            if index is None:
                index = self.series(SeriesKind.TIMESTAMP, shape, prefix="time")
            out.append(self.series(kind, shape, index=index))
        return out

    def many_statuses(self, series: list[MetricsData]) -> list[MetricsData] | None:
        if self.draw(st.booleans()):
            return None
        return [
            self.series(SeriesKind.STATUS, s.shape(), index=s.index, prefix="statuses")
            for s in series
        ]

    def legend(self, n: int) -> list[str] | None:
        legend: list[str] | None = self.draw(
            st.one_of(st.none(), st.lists(_WORDS, min_size=n, max_size=n))
        )
        return legend

    def double_over_time(self, name: str, opts: dict[str, Any]) -> MetricHandle:
        n = self.draw(st.integers(1, 3))
        series = self.timed(n, SeriesKind.DOUBLE)
        failures = self.draw(
            st.one_of(
                st.none(), st.lists(st.tuples(_opt_float(), _opt_float()), min_size=n, max_size=n)
            )
        )
        return self.writer.double_over_time(
            name,
            series if n > 1 or self.draw(st.booleans()) else series[0],
            statuses=self.many_statuses(series),
            failures=failures,
            start_time=self.draw(st.one_of(st.none(), _TIMESTAMPS)),
            end_time=self.draw(st.one_of(st.none(), _TIMESTAMPS)),
            y_axis_name=self.draw(st.one_of(st.none(), _WORDS)),
            legend=self.legend(n),
            **opts,
        )

    def line_plot(self, name: str, opts: dict[str, Any]) -> MetricHandle:
        xs, ys = [], []
        for _ in range(self.draw(st.integers(1, 3))):
            shape = self.shape()
            index = self.maybe_index(shape, [None, SeriesKind.TIMESTAMP], chain=False)
            xs.append(self.series(SeriesKind.DOUBLE, shape, index=index))
            ys.append(self.series(SeriesKind.DOUBLE, shape, index=index))
        return self.writer.line_plot(
            name,
            xs,
            ys,
            statuses=self.many_statuses(xs),
            x_axis_name=self.draw(st.one_of(st.none(), _WORDS)),
            y_axis_name=self.draw(st.one_of(st.none(), _WORDS)),
            legend=self.legend(len(xs)),
            **opts,
        )

    def bar_chart(self, name: str, opts: dict[str, Any]) -> MetricHandle:
        if self.draw(st.booleans()):
            bars = self.draw(st.dictionaries(_WORDS, _FLOATS, min_size=1, max_size=4))
            return self.writer.bar_chart_from(name, bars, **opts)
        shape = self.shape()
        labels = self.series(SeriesKind.STRING, shape, prefix="labels")
        n = self.draw(st.integers(1, 3))
        series = [self.series(SeriesKind.DOUBLE, shape, index=labels) for _ in range(n)]
        return self.writer.bar_chart(
            name,
            series,
            statuses=self.many_statuses(series),
            x_axis_name=self.draw(st.one_of(st.none(), _WORDS)),
            y_axis_name=self.draw(st.one_of(st.none(), _WORDS)),
            legend=self.legend(n),
            stack_bars=self.draw(st.one_of(st.none(), st.booleans())),
            **opts,
        )

    def states_over_time(self, name: str, opts: dict[str, Any]) -> MetricHandle:
        n = self.draw(st.integers(1, 2))
        states = self.timed(n, SeriesKind.STRING)
        seen = sorted(
            {str(v) for s in states for v in _flat(s)},
        )
        states_set = None
        if self.draw(st.booleans()):
            extra = self.draw(st.lists(st.sampled_from(["crash", "park"]), unique=True))
            states_set = self.draw(st.permutations(seen + extra))
        allowed = states_set if states_set is not None else seen
        failure_states = self.draw(st.lists(st.sampled_from(allowed), unique=True))
        return self.writer.states_over_time(
            name,
            states,
            states_set=states_set,
            failure_states=failure_states,
            statuses=self.many_statuses(states),
            legend=self.legend(n),
            **opts,
        )

    def histogram(self, name: str, opts: dict[str, Any]) -> MetricHandle:
        values = self.pooled_doubles([None, SeriesKind.TIMESTAMP, SeriesKind.STRING])
        lower = float(self.draw(st.integers(-100, 100)))
        if self.draw(st.booleans()):
            count = self.draw(st.integers(1, 6))
            upper = lower + self.draw(st.integers(1, 50))
            buckets: Any = count
        else:
            edges = [lower]
            for width in self.draw(st.lists(st.floats(0.5, 100.0), min_size=1, max_size=4)):
                edges.append(edges[-1] + width)
            buckets = list(itertools.pairwise(edges))
            upper = edges[-1]
            if self.draw(st.booleans()):
                lower, upper = None, None  # type: ignore[assignment]
        return self.writer.histogram(
            name,
            values,
            buckets=buckets,
            lower=lower,
            upper=upper,
            statuses=self.statuses_for(values),
            x_axis_name=self.draw(st.one_of(st.none(), _WORDS)),
            **opts,
        )

    def batchwise_bar_chart(self, name: str, opts: dict[str, Any]) -> MetricHandle:
        n = self.draw(st.integers(1, 3))
        times, values = [], []
        for _ in range(n):
            shape = self.shape()
            batches = self.series(SeriesKind.UUID, shape, prefix="batches")
            times.append(self.series(SeriesKind.TIMESTAMP, shape, index=batches))
            values.append(self.series(SeriesKind.DOUBLE, shape, index=batches))
        return self.writer.batchwise_bar_chart(
            name,
            project_id=self.draw(st.uuids()),
            times=times,
            values=values,
            categories=self.draw(st.lists(_WORDS, min_size=n, max_size=n)),
            statuses=self.many_statuses(values),
            colors=self.draw(st.lists(_COLORS, max_size=n)),
            x_axis_name=self.draw(st.one_of(st.none(), _WORDS)),
            y_axis_name=self.draw(st.one_of(st.none(), _WORDS)),
            stack_bars=self.draw(st.one_of(st.none(), st.booleans())),
            **opts,
        )

    def text(self, name: str, opts: dict[str, Any]) -> MetricHandle:
        return self.writer.text(name, self.draw(st.text(min_size=1, max_size=20)), **opts)

    def plotly(self, name: str, opts: dict[str, Any]) -> MetricHandle:
        scalars = st.one_of(st.none(), st.booleans(), _FINITE, st.text(max_size=5))
        doc = self.draw(
            st.recursive(
                st.dictionaries(st.text(max_size=5), scalars, max_size=3),
                lambda inner: st.dictionaries(
                    st.text(max_size=5), st.one_of(inner, st.lists(inner, max_size=2)), max_size=3
                ),
                max_leaves=6,
            )
        )
        figure: Any = json.dumps(doc) if self.draw(st.booleans()) else doc
        return self.writer.plotly(name, figure, **opts)

    def image_file(self) -> MetricsData:
        pool = self.pool.setdefault("images", [])
        if pool and self.draw(st.booleans()):
            return self.draw(st.sampled_from(pool))  # type: ignore[no-any-return]
        image = data.external_file(self.name("image"), f"images/{self.counter}.png")
        pool.append(image)
        return image

    def image(self, name: str, opts: dict[str, Any]) -> MetricHandle:
        return self.writer.image(name, self.image_file(), **opts)

    def image_list(self, name: str, opts: dict[str, Any]) -> MetricHandle:
        images = {
            id(i): i for i in (self.image_file() for _ in range(self.draw(st.integers(1, 3))))
        }
        return self.writer.image_list(name, list(images.values()), **opts)

    def add_data(self) -> None:
        kind = self.draw(st.sampled_from(_SERIES_KINDS))
        shape = self.shape()
        index = self.maybe_index(shape, [None, *_SERIES_KINDS])
        self.writer.add_data(self.series(kind, shape, index=index, prefix="alone"))

    def events(self) -> None:
        relative = self.draw(st.booleans())
        unused = list(self.event_metrics)
        for i in range(self.draw(st.integers(0, 3))):
            chosen: list[MetricHandle] = []
            for handle in self.draw(st.permutations(unused)):
                if handle.name not in {c.name for c in chosen} and self.draw(st.booleans()):
                    chosen.append(handle)
            self.writer.event(
                f"event {i}",
                timestamp=self.draw(_TIMESTAMPS),
                relative=relative,
                metrics=chosen,
                status=self.draw(_STATUSES),
                importance=self.draw(_IMPORTANCES),
                description=self.draw(st.text(max_size=5)),
                tags=self.draw(st.lists(_WORDS, max_size=2)),
            )

    def run(self) -> None:
        builders: dict[MetricType, Callable[[str, dict[str, Any]], MetricHandle]] = {
            MetricType.SCALAR: self.scalar,
            MetricType.DOUBLE_SUMMARY: self.double_summary,
            MetricType.DOUBLE_OVER_TIME: self.double_over_time,
            MetricType.LINE_PLOT: self.line_plot,
            MetricType.BAR_CHART: self.bar_chart,
            MetricType.STATES_OVER_TIME: self.states_over_time,
            MetricType.HISTOGRAM: self.histogram,
            MetricType.BATCHWISE_BAR_CHART: self.batchwise_bar_chart,
            MetricType.TEXT: self.text,
            MetricType.PLOTLY: self.plotly,
            MetricType.IMAGE: self.image,
            MetricType.IMAGE_LIST: self.image_list,
        }
        for _ in range(self.draw(st.integers(0, 5))):
            if self.draw(st.integers(0, 5)) == 0:
                self.add_data()
                continue
            metric_type = self.draw(st.sampled_from(list(builders)))
            opts = self.options()
            event = self.draw(st.integers(0, 4)) == 0
            if event:
                opts["event"] = True
                # Event metrics may share names; draw from a small set.
                name = self.draw(st.sampled_from(["event metric a", "event metric b"]))
            else:
                name = self.name(metric_type.name.lower())
            handle = builders[metric_type](name, opts)
            assert handle.type is metric_type
            self.decorate(handle)
            self.made.append(metric_type)
            if event:
                self.event_metrics.append(handle)
        self.events()
        if self.draw(st.integers(0, 4)) == 0:
            self.writer.override_status(self.draw(st.one_of(st.none(), _STATUSES)))


def _opt_float() -> st.SearchStrategy[float | None]:
    return st.one_of(st.none(), _FINITE)


def _flat(d: MetricsData) -> list[Any]:
    if isinstance(d.values, dict):
        return [v for vs in d.values.values() for v in vs]
    return list(d.values or [])


def assert_conforms(payload: bytes) -> rp.JobMetrics:
    """Both validators accept the bytes, and ReSim's classes re-serialize them unchanged."""
    resim_msg = rp.JobMetrics.FromString(payload)
    resim_validate(resim_msg)
    assert resim_msg.SerializeToString(deterministic=True) == payload
    view = read_job_metrics(payload)
    problems = find_problems(view.raw)
    assert problems == [], "\n".join(map(str, problems))
    return resim_msg


@examples(100)
@given(st.data(), st.uuids(), st.booleans())
def test_any_legal_writer_program_gives_an_output_resim_accepts(
    drawn: st.DataObject, job_id: uuid.UUID, deterministic: bool
) -> None:
    writer = MetricsWriter(job_id, deterministic=deterministic)
    program = Program(drawn.draw, writer)
    program.run()
    payload = writer.serialize()
    resim_msg = assert_conforms(payload)
    # The output holds what the program wrote.
    view = read_job_metrics(payload)
    assert [m.type for m in view.metrics] == program.made
    assert len(resim_msg.job_level_metrics.metrics) == len(program.made)
    assert view.status is writer.status
    assert view.job_id == job_id
    names = [d.name for d in view.data]
    assert len(names) == len(set(names))
    # Every reference and every index resolves to data in the output.
    for metric in view.metrics:
        assert set(metric.data_ids) <= set(view.data_by_id)
    for d in view.data:
        assert d.index_id is None or d.index_id in view.data_by_id
    if deterministic:
        assert writer.serialize() == payload


def test_the_sdk_example_covers_every_metric_type_and_conforms(tmp_path: Path) -> None:
    writer = MetricsWriter(uuid.UUID(int=42), deterministic=True)
    every_metric_type(tmp_path, tmp_path, writer)
    payload = writer.serialize()
    resim_msg = assert_conforms(payload)
    types = {m.type for m in resim_msg.job_level_metrics.metrics}
    assert types == {int(t) for t in MetricType}
    assert len(types) == 12
    view = read_job_metrics(payload)
    assert {d.kind for d in view.data} == set(SeriesKind)
    assert any(d.per_category for d in view.data)
    assert any(d.indexed for d in view.data)
    assert len(view.events) == 1
    # Writing to a file validates again and gives the same bytes.
    out = writer.write(tmp_path / "metrics.binproto")
    assert out.read_bytes() == payload


def test_timestamps_from_datetimes_and_ints_agree() -> None:
    # The property test mixes both spellings; they must name the same instant.
    moment = datetime(2030, 5, 6, 7, 8, 9, 123456, tzinfo=UTC)
    ns = (moment - _EPOCH) // timedelta(microseconds=1) * 1000
    assert data.timestamps("a", [moment]).values == data.timestamps("b", [ns]).values
