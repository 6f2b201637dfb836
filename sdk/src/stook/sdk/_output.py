"""The output a writer builds: its metrics, metrics data and events, and their encoding.

`OutputBuilder` holds the state of one JobMetrics output (test, batch or report
metrics) and everything about it that does not depend on a metric's type: metrics data
with their index chains and IDs, the generated status series, the metric protos and
their names, events, the overall status, and turning all of it into a validated
``metrics.binproto``. `MetricsWriter` (in `_writer`) adds one method per metric type on
top; `all_or_nothing` is what keeps a failed metric call from leaving a trace here.

Each metric method builds its proto at once and returns a `MetricHandle` on it; the
handle's setters change that proto in place and return the handle, so that calls chain
(``w.scalar(...).describe(...).importance(...)``). `MetricOptions` is the set of
keyword arguments shared by every metric type.

IDs come from an `IdScheme`: random UUIDs, or (``deterministic=True``) UUIDs derived
from names, so that the same input gives byte-identical output, as tests, caches and
reproducible batch runs want. The encoders (`data_to_proto`, `timestamp_proto`,
`failure_proto`, ...) own how SDK values become schema messages and nothing about which
metric needs which message; everything they do is deterministic. `write_atomic` writes
the file so that readers see the old content or the whole new one, never a part (the
service writes its other files with it too).
"""

from __future__ import annotations

import contextlib
import functools
import os
import re
import secrets
import uuid
from collections import Counter
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any, Concatenate, ParamSpec, Self, TypedDict, TypeVar

from google.protobuf import timestamp_pb2

from stook.proto import metrics_pb2 as pb
from stook.proto import uuid_pb2
from stook.sdk import _data
from stook.sdk._data import MetricsData, TimestampLike, UuidLike
from stook.sdk._enums import (
    SERIES_FIELD,
    MetricImportance,
    MetricStatus,
    MetricType,
    SeriesKind,
    data_type_of,
)
from stook.sdk._errors import OutputWriteError, WriterError
from stook.sdk._validate import validate_job_metrics

# Temporary names are tempfile.mkstemp's: `.{name}.` + 8 of these + `.tmp`, so that files
# left by earlier versions, which used mkstemp, are recognised as stale too.
_TEMP_CHARS = "abcdefghijklmnopqrstuvwxyz0123456789_"
_TEMP_RANDOM_LENGTH = 8


def _temp_path(target: Path) -> Path:
    random = "".join(secrets.choice(_TEMP_CHARS) for _ in range(_TEMP_RANDOM_LENGTH))
    return target.parent / f".{target.name}.{random}.tmp"


def _is_temp_name(name: str, target_name: str) -> bool:
    pattern = rf"\.{re.escape(target_name)}\.[{_TEMP_CHARS}]{{{_TEMP_RANDOM_LENGTH}}}\.tmp"
    return re.fullmatch(pattern, name) is not None


def _naming_the_path(
    write: Callable[[str | os.PathLike[str], bytes], Path],
) -> Callable[[str | os.PathLike[str], bytes], Path]:
    """Turn an OSError of the write into an OutputWriteError that names the path.

    ENOSPC from a write() or fsync() names no file, so without this a full disk reads
    ``[Errno 28] No space left on device`` with no hint of where.
    """

    @functools.wraps(write)
    def naming(path: str | os.PathLike[str], content: bytes) -> Path:
        try:
            return write(path, content)
        except OutputWriteError:
            raise
        except OSError as exc:
            raise OutputWriteError(
                exc.errno, exc.strerror or str(exc) or type(exc).__name__, os.fspath(path)
            ) from exc

    return naming


@_naming_the_path
def write_atomic(path: str | os.PathLike[str], content: bytes) -> Path:
    """Write `content` to `path` via a temporary file in the same folder and a rename.

    The rename is atomic on POSIX within one file system, which is why the
    temporary file lives beside the target rather than in /tmp. The data is
    fsync'ed before the rename so that a crash cannot leave a renamed but
    empty file behind.

    Whatever interrupts the write (an error, or an exception that a signal handler
    raises at any point after the temporary file is created) removes the temporary
    file: its name is chosen before it is created, so even an interruption right after
    the creation knows what to remove. Only SIGKILL or a crash can leave one behind;
    `remove_stale_temp_files` clears those.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp_name = _temp_path(target)
    ours = True
    try:
        try:
            fd = os.open(tmp_name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o600)
        except FileExistsError:
            ours = False  # another writer's file of the same random name: not ours to remove
            raise
        with os.fdopen(fd, "wb") as tmp:
            tmp.write(content)
            tmp.flush()
            os.fsync(tmp.fileno())
        os.chmod(tmp_name, 0o644)
        os.replace(tmp_name, target)
    except BaseException:
        if ours:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(tmp_name)
        raise
    with contextlib.suppress(OSError):
        dir_fd = os.open(target.parent, os.O_RDONLY)
        try:
            os.fsync(dir_fd)
        finally:
            os.close(dir_fd)
    return target


def remove_stale_temp_files(path: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary files that killed `write_atomic(path, ...)` calls left beside
    `path`, and return them.

    Only names of write_atomic's own pattern for this target are touched
    (`.metrics.binproto.` + 8 characters + `.tmp` for metrics.binproto), never other
    files. Best effort: a folder that is missing or cannot be listed has nothing to remove.
    """
    target = Path(path)
    removed: list[Path] = []
    try:
        entries = list(os.scandir(target.parent))
    except OSError:
        return removed
    for entry in entries:
        if _is_temp_name(entry.name, target.name) and entry.is_file(follow_symlinks=False):
            with contextlib.suppress(FileNotFoundError):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
    return removed


_STOOK_NAMESPACE = uuid.UUID("5d1f3c8e-6a0b-4c2e-9f3a-7b1e2d4c6a80")


class IdScheme:
    """Hands out metric, data and event IDs for one output."""

    def __init__(self, job_id: uuid.UUID, *, deterministic: bool) -> None:
        self.deterministic = deterministic
        self._namespace = uuid.uuid5(_STOOK_NAMESPACE, str(job_id))
        self._uses: Counter[str] = Counter()

    def _derive(self, kind: str, name: str) -> uuid.UUID:
        key = f"{kind}:{name}"
        self._uses[key] += 1
        n = self._uses[key]
        # Event metrics may share a name; the counter keeps their IDs apart, in its own
        # prefix so that no name can spell another's repeat ("a#2" is not "a", twice).
        return uuid.uuid5(self._namespace, key if n == 1 else f"{kind}#{n}:{name}")

    def metric_id(self, name: str) -> uuid.UUID:
        return self._derive("metric", name) if self.deterministic else uuid.uuid4()

    def event_id(self, name: str) -> uuid.UUID:
        return self._derive("event", name) if self.deterministic else uuid.uuid4()

    def data_id(self, name: str, own_id: uuid.UUID) -> uuid.UUID:
        return uuid.uuid5(self._namespace, f"data:{name}") if self.deterministic else own_id


def uuid_proto(value: uuid.UUID) -> uuid_pb2.UUID:
    return uuid_pb2.UUID(data=str(value))


def timestamp_proto(ns: int) -> timestamp_pb2.Timestamp:
    seconds, nanos = divmod(ns, 1_000_000_000)
    return timestamp_pb2.Timestamp(seconds=seconds, nanos=nanos)


def failure_proto(above: float | None, below: float | None) -> pb.DoubleFailureDefinition:
    f = pb.DoubleFailureDefinition()
    if above is not None:
        f.fails_above = above
    if below is not None:
        f.fails_below = below
    return f


def data_to_proto(data: MetricsData, ids: Mapping[str, uuid.UUID]) -> pb.MetricsData:
    """The proto of one metrics-data item, with IDs as the writer assigned them."""
    msg = pb.MetricsData(
        metrics_data_id=pb.MetricsDataId(id=uuid_proto(ids[data.name])),
        data_type=data_type_of(data.kind, indexed=data.indexed),
        name=data.name,
        unit=data.unit,
    )
    if data.kind is SeriesKind.EXTERNAL_FILE:
        msg.external_file.path = data.external_path or ""
        return msg
    if data.index is not None:
        msg.is_indexed = True
        msg.index_data_id.CopyFrom(pb.MetricsDataId(id=uuid_proto(ids[data.index.name])))
        msg.index_data_type = data_type_of(data.index.kind, indexed=data.index.indexed)
    if isinstance(data.values, dict):
        msg.is_per_category = True
        msg.category_names.extend(data.values)
        for category, values in data.values.items():
            _fill_series(msg.series_per_category.category_to_series[category], data.kind, values)
    else:
        _fill_series(msg.series, data.kind, data.values or [])
    return msg


def _fill_series(series: pb.Series, kind: SeriesKind, values: Sequence[Any]) -> None:
    target = getattr(series, SERIES_FIELD[kind])
    target.SetInParent()
    match kind:
        case SeriesKind.TIMESTAMP:
            target.series.extend(timestamp_proto(v) for v in values)
        case SeriesKind.UUID:
            target.series.extend(uuid_pb2.UUID(data=v) for v in values)
        case _:
            target.series.extend(values)


class MetricOptions(TypedDict, total=False):
    """What every metric type takes besides its values."""

    status: MetricStatus  # default PASSED
    description: str
    importance: MetricImportance  # default MEDIUM
    blocking: bool
    event: bool  # written for an event (see MetricsWriter.event); names may repeat


def status_of(options: MetricOptions) -> MetricStatus:
    return options.get("status", MetricStatus.PASSED)


FailureDefinition = tuple[float | None, float | None]


class MetricHandle:
    """A metric in a writer; its setters change it in place and return it for chaining."""

    def __init__(self, writer: OutputBuilder, proto: pb.Metric) -> None:
        self._writer = writer
        self._proto = proto

    @property
    def name(self) -> str:
        return self._proto.name

    @property
    def type(self) -> MetricType:
        return MetricType(self._proto.type)

    @property
    def id(self) -> uuid.UUID:
        return uuid.UUID(self._proto.metric_id.id.data)

    @property
    def proto(self) -> pb.Metric:
        return self._proto

    def describe(self, description: str) -> Self:
        self._proto.description = description
        return self

    def status(self, status: MetricStatus) -> Self:
        self._proto.status = pb.MetricStatus.ValueType(MetricStatus(status))
        return self

    def blocking(self, blocking: bool = True) -> Self:
        self._proto.blocking = blocking
        return self

    def importance(self, importance: MetricImportance) -> Self:
        self._proto.importance = pb.MetricImportance.ValueType(MetricImportance(importance))
        return self

    def display(self, should_display: bool = True) -> Self:
        self._proto.should_display = should_display
        return self

    def order(self, order: float) -> Self:
        self._proto.order = order
        return self

    def tag(self, key: str, value: str) -> Self:
        if not key or not value:
            raise WriterError(f"metric {self.name!r}: a tag needs a non-empty key and value")
        self._proto.tags.add(key=key, value=value)
        return self


_B = TypeVar("_B", bound="OutputBuilder")
_P = ParamSpec("_P")
_R = TypeVar("_R")


def all_or_nothing(
    method: Callable[Concatenate[_B, _P], _R],
) -> Callable[Concatenate[_B, _P], _R]:
    """A metric call that fails leaves the writer as it was: no half-built metric, no
    reserved name, no data written on its behalf."""

    @functools.wraps(method)
    def wrapper(self: _B, /, *args: _P.args, **kwargs: _P.kwargs) -> _R:
        metrics, data = len(self._metrics), len(self._data)
        try:
            return method(self, *args, **kwargs)
        except BaseException:
            self._roll_back(metrics, data)
            raise

    return wrapper


class OutputBuilder:
    """One output as it is being built; `MetricsWriter` adds a method per metric type."""

    def __init__(self, job_id: UuidLike, *, deterministic: bool = False) -> None:
        try:
            self.job_id = job_id if isinstance(job_id, uuid.UUID) else uuid.UUID(str(job_id))
        except ValueError:
            raise WriterError(f"job ID {job_id!r} is not a UUID") from None
        self._ids = IdScheme(self.job_id, deterministic=deterministic)
        self._metrics: list[pb.Metric] = []
        self._metric_names: set[str] = set()
        self._data: dict[str, MetricsData] = {}
        self._data_ids: dict[str, uuid.UUID] = {}
        self._events: list[pb.Event] = []
        self._status_override: MetricStatus | None = None
        self._made_statuses: dict[tuple[str, MetricStatus], MetricsData] = {}

    # ---- data ----

    def add_data(self, *items: MetricsData) -> None:
        """Write data (and its index chain) into the output, referenced or not."""
        for item in items:
            for node in item.dependencies():
                known = self._data.get(node.name)
                if known is node:
                    continue
                if known is not None:
                    raise WriterError(f"two different metrics data are named {node.name!r}")
                _check_not_empty(node)
                self._data[node.name] = node
                self._data_ids[node.name] = self._ids.data_id(node.name, node.id)

    def _roll_back(self, metrics: int, data: int) -> None:
        del self._metrics[metrics:]
        for name in list(self._data)[data:]:
            del self._data[name]
            del self._data_ids[name]
        self._metric_names = {m.name for m in self._metrics if not m.event_metric}
        self._made_statuses = {
            k: v for k, v in self._made_statuses.items() if self._data.get(v.name) is v
        }

    def _ref(self, item: MetricsData) -> pb.MetricsDataId:
        self.add_data(item)
        return pb.MetricsDataId(id=uuid_proto(self._data_ids[item.name]))

    @property
    def data(self) -> list[MetricsData]:
        return list(self._data.values())

    # ---- metrics: shared plumbing ----

    def _new_metric(
        self, name: str, metric_type: MetricType, options: MetricOptions
    ) -> tuple[pb.Metric, MetricHandle]:
        if not name:
            raise WriterError("a metric needs a non-empty name")
        event = options.get("event", False)
        if not event:
            if name in self._metric_names:
                raise WriterError(f"a metric named {name!r} was already written")
            self._metric_names.add(name)
        proto = pb.Metric(
            metric_id=pb.MetricId(id=uuid_proto(self._ids.metric_id(name))),
            name=name,
            type=pb.MetricType.ValueType(metric_type),
            description=options.get("description", ""),
            job_id=pb.JobId(id=uuid_proto(self.job_id)),
        )
        handle = MetricHandle(self, proto)
        handle.status(status_of(options))
        handle.importance(options.get("importance", MetricImportance.MEDIUM))
        if "blocking" in options:
            handle.blocking(options["blocking"])
        if event:
            proto.event_metric = True
        self._metrics.append(proto)
        return proto, handle

    def _statuses_for(
        self, values: MetricsData, statuses: MetricsData | None, status: MetricStatus
    ) -> MetricsData:
        if statuses is not None:
            return statuses
        # One generated status series per (data, status), so that two metrics over the
        # same data share it instead of colliding on its name.
        key = (values.name, status)
        made = self._made_statuses.get(key)
        if made is None:
            made = _data.status_like(values, status, name=f"{values.name} ({status.name} status)")
            self._made_statuses[key] = made
        return made

    # ---- events ----

    def event(
        self,
        name: str,
        *,
        timestamp: TimestampLike,
        relative: bool = False,
        metrics: Sequence[MetricHandle] = (),
        status: MetricStatus = MetricStatus.PASSED,
        importance: MetricImportance = MetricImportance.MEDIUM,
        description: str = "",
        tags: Sequence[str] = (),
    ) -> None:
        """An event at a point in the test, optionally with metrics written with `event=True`.

        All events of one output share one timestamp type (absolute or relative)."""
        if not name or any(e.name == name for e in self._events):
            raise WriterError(f"event names must be non-empty and unique: {name!r}")
        if _data.timestamp_ns(timestamp) < 0:
            raise WriterError(f"event {name!r}: timestamps before 1970 (or negative) are refused")
        kind = pb.RELATIVE_TIMESTAMP if relative else pb.ABSOLUTE_TIMESTAMP
        if self._events and self._events[0].timestamp_type != kind:
            raise WriterError(f"event {name!r}: all events must be all absolute or all relative")
        names = [m.name for m in metrics]
        if len(set(names)) != len(names):
            raise WriterError(f"event {name!r}: its metrics need unique names")
        for m in metrics:
            if not m.proto.event_metric:
                raise WriterError(
                    f"event {name!r}: metric {m.name!r} was not written with event=True"
                )
        self._events.append(
            pb.Event(
                event_id=pb.EventId(id=uuid_proto(self._ids.event_id(name))),
                name=name,
                description=description,
                tags=list(tags),
                metrics=[pb.MetricId(id=uuid_proto(m.id)) for m in metrics],
                status=pb.MetricStatus.ValueType(MetricStatus(status)),
                timestamp=timestamp_proto(_data.timestamp_ns(timestamp)),
                timestamp_type=kind,
                importance=pb.MetricImportance.ValueType(MetricImportance(importance)),
            )
        )

    # ---- status and output ----

    def override_status(self, status: MetricStatus | None) -> None:
        """Set the output's overall status instead of computing it (None: compute again)."""
        self._status_override = None if status is None else MetricStatus(status)

    @property
    def status(self) -> MetricStatus:
        """The overall status: the override, else FAIL_BLOCK if any metric blocks, else
        FAIL_WARN if any warns, else PASSED."""
        if self._status_override is not None:
            return self._status_override
        statuses = {m.status for m in self._metrics}
        if pb.FAIL_BLOCK_METRIC_STATUS in statuses:
            return MetricStatus.FAIL_BLOCK
        if pb.FAIL_WARN_METRIC_STATUS in statuses:
            return MetricStatus.FAIL_WARN
        return MetricStatus.PASSED

    def has_metric(self, name: str) -> bool:
        """Whether a (non-event) metric of this name was written."""
        return name in self._metric_names

    @property
    def metrics(self) -> list[MetricHandle]:
        return [MetricHandle(self, m) for m in self._metrics]

    def to_proto(self) -> pb.JobMetrics:
        """The JobMetrics message as it stands now."""
        status = pb.MetricStatus.ValueType(self.status)
        msg = pb.JobMetrics(
            job_id=pb.JobId(id=uuid_proto(self.job_id)),
            metrics_status=status,
            events=self._events,
        )
        msg.job_level_metrics.metrics_status = status
        msg.job_level_metrics.metrics.extend(self._metrics)
        msg.metrics_data.extend(data_to_proto(d, self._data_ids) for d in self._data.values())
        return msg

    def serialize(self) -> bytes:
        # Deterministic serialization orders map entries, so equal inputs give equal bytes.
        return self.to_proto().SerializeToString(deterministic=True)

    def write(self, path: str | Path, *, validate: bool = True) -> Path:
        """Validate, then write metrics.binproto atomically; on an invalid output nothing
        is written and InvalidMetricsError says which metric breaks which rule."""
        msg = self.to_proto()
        if validate:
            validate_job_metrics(msg)
        return write_atomic(path, msg.SerializeToString(deterministic=True))


def _check_not_empty(data: MetricsData) -> None:
    # The platform refuses a series (or a category) with no elements.
    if data.kind is SeriesKind.EXTERNAL_FILE:
        return
    shape = data.shape()
    lengths = shape.values() if isinstance(shape, dict) else [shape]
    if any(n == 0 for n in lengths):
        raise WriterError(f"metrics data {data.name!r} is empty; the platform refuses empty series")
