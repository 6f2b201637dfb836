"""A batch's summary: what report mode needs of its jobs, written once by batch mode.

Report mode otherwise lists every job and every job's metrics of every batch it reads.
Batch mode has all of that in hand, so it also writes a compact summary of it as one
metrics data item referenced by no metric (`SUMMARY_DATA_NAME`): a STRING series of one
element, the base64 of the binary layout below. A report then reads one listing and one
download per batch. See docs/batch-summaries.md.

Layout (little-endian), version 1; columnar so that decoding a thousand jobs is a few
`struct` calls, and sorted throughout so that equal batches give equal bytes:

    b"STKS" u16 version
    u8 width                       bytes of every index below (1, 2 or 4)
    u32 strings, each u32 length + UTF-8          (sorted: names, statuses, units)
    u32 experiences, each u8 has-id, 16 id bytes, index of its name
    u32 jobs: job IDs (16 bytes each, sorted); per job the index of its experience, the
        index of its conflated status; a bitmap of the jobs that have metrics
    u32 scalar metrics (sorted by name), each: name index, bitmap of the jobs that have
        it, their values (f64), the index of each value's unit
    u32 job metric statuses, each: status index, u32 count

A summary of a newer version than this code knows raises `SummaryVersionError`: the
reader falls back to the listings instead of guessing at its meaning.
"""

from __future__ import annotations

import base64
import operator
import struct
import uuid
from collections import Counter
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from itertools import chain, repeat
from typing import TYPE_CHECKING, Any, Final, Literal, Self

from stook.sdk._data import strings
from stook.sdk._errors import SummaryError, SummaryVersionError
from stook.sdk.aggregations._base import Aggregation, JobRecord, Needs, Scalar
from stook.sdk.aggregations._columns import JobColumns, ScalarColumn, values_by_name
from stook.sdk.aggregations._status_counts import COUNT_BATCH

if TYPE_CHECKING:
    import numpy as np

    from stook.sdk._views import MetricsDataView
    from stook.sdk._writer import MetricsWriter

#: the name of the metrics data that holds a batch's summary
SUMMARY_DATA_NAME = "stook batch summary"
#: the newest summary layout this code writes and reads
SUMMARY_VERSION = 1

_MAGIC = b"STKS"
_U8 = struct.Struct("<B")
_U16 = struct.Struct("<H")
_U32 = struct.Struct("<I")
_WIDTH_CODES = {1: "B", 2: "H", 4: "I"}
_NO_ID = bytes(16)


@dataclass(frozen=True, slots=True)
class SummaryJob:
    """One job of a summary: its facts, whether it has metrics, and its SCALAR job
    metrics as (value, unit) by name."""

    job_id: uuid.UUID
    experience_name: str
    conflated_status: str
    experience_id: uuid.UUID | None = None
    has_metrics: bool = False
    scalars: Mapping[str, tuple[float, str]] = field(default_factory=dict, hash=False)


@dataclass(frozen=True, slots=True)
class BatchSummary:
    """A batch's jobs (sorted by ID) and the counts of its job metrics' statuses."""

    jobs: tuple[SummaryJob, ...] = ()
    metric_statuses: Mapping[str, int] = field(default_factory=dict, hash=False)


@dataclass(frozen=True, slots=True, eq=False)
class ColumnarSummary:
    """A summary as report mode folds it: the batch's jobs as `JobColumns` (what a
    report reads of their per-job listings) and how many of them have metrics."""

    columns: JobColumns
    jobs_with_metrics: int


# ---- encoding ----


def encode_summary(summary: BatchSummary) -> bytes:
    """The summary's bytes (version `SUMMARY_VERSION`); equal summaries, equal bytes."""
    rows = [
        (j.job_id, j.experience_name, j.conflated_status, j.experience_id, j.has_metrics, j.scalars)
        for j in summary.jobs
    ]
    return _encode(rows, summary.metric_statuses, _PAIR_PARTS)


# A job as the encoder takes it: ID, experience name, conflated status, experience ID,
# whether it has metrics, and its scalars by name as (value, unit) pairs or as `Scalar`s.
_Row = tuple[uuid.UUID, str, str, uuid.UUID | None, bool, Mapping[str, Any]]
_PAIR_PARTS = (operator.itemgetter(0), operator.itemgetter(1))
_FIRST = operator.itemgetter(0)
_INT = operator.attrgetter("int")
_BIG: Final[Literal["big"]] = "big"
_SCALAR_PARTS = (operator.attrgetter("value"), operator.attrgetter("unit"))


def _encode(
    rows: Iterable[_Row],
    metric_statuses: Mapping[str, int],
    parts: tuple[Callable[[Any], float], Callable[[Any], str]],
) -> bytes:
    """`encode_summary` of the jobs as rows; `parts` takes a scalar's value and unit apart.

    Batch mode encodes its thousand jobs' rows here, so the per-job and per-scalar work is
    done by C loops (map, filter, set.union) where it can be, and each UUID's bytes made
    once (`UUID.bytes` is Python code)."""
    given = list(rows)
    # In job-ID order: by the IDs' ints, which order as their big-endian bytes do (and
    # are read and compared in C; `UUID.bytes` is Python code), their bytes made from them.
    ids = list(map(_INT, map(_FIRST, given)))
    order = sorted(range(len(given)), key=ids.__getitem__)
    jobs = list(map(given.__getitem__, order))
    job_ids = b"".join(map(int.to_bytes, map(ids.__getitem__, order), repeat(16), repeat(_BIG)))
    # By the IDs' ints, which hash in C (a UUID's __hash__ is Python code); a batch has
    # few experiences, so few bytes to make.
    experience_ids = {row[3].int: row[3] for row in jobs if row[3] is not None}
    id_bytes = {key: experience_id.bytes for key, experience_id in experience_ids.items()}
    job_experiences = [(row[1], _NO_ID if row[3] is None else id_bytes[row[3].int]) for row in jobs]
    scalars = [row[5] for row in jobs]
    value_of, unit_of = parts
    metric_names = sorted(set().union(*scalars))
    # Per metric, each job's scalar or None (a job without it), then the scalars there
    # are and their units.
    by_job = values_by_name(scalars, metric_names)
    found = [list(filter(None, column)) for column in by_job]
    units = [list(map(unit_of, column)) for column in found]
    experiences = sorted(set(job_experiences))
    statuses = [row[2] for row in jobs]
    texts = sorted(
        {name for name, _ in experiences}
        | set(statuses)
        | set(metric_names)
        | set().union(*units)
        | set(metric_statuses)
    )
    text_index = {t: i for i, t in enumerate(texts)}
    experience_index = {e: i for i, e in enumerate(experiences)}
    width = _width(max(len(texts), len(experiences)))
    code = _WIDTH_CODES[width]
    out = bytearray(_MAGIC + _U16.pack(SUMMARY_VERSION) + _U8.pack(width))
    out += _U32.pack(len(texts))
    for text in texts:
        encoded = text.encode()
        out += _U32.pack(len(encoded)) + encoded
    out += _U32.pack(len(experiences))
    for name, experience_id in experiences:
        out += _U8.pack(experience_id != _NO_ID) + experience_id + _index(code, text_index[name])
    out += _U32.pack(len(jobs))
    out += job_ids
    out += _indexes(code, list(map(experience_index.__getitem__, job_experiences)))
    out += _indexes(code, list(map(text_index.__getitem__, statuses)))
    out += _bitmap([row[4] for row in jobs])
    out += _U32.pack(len(metric_names))
    for name, column, present, present_units in zip(
        metric_names, by_job, found, units, strict=True
    ):
        out += _index(code, text_index[name]) + _bitmap(column)
        out += struct.pack(f"<{len(present)}d", *map(value_of, present))
        out += _unit_indexes(code, present_units, text_index)
    counted = sorted(metric_statuses.items())
    out += _U32.pack(len(counted))
    for status, count in counted:
        out += _index(code, text_index[status]) + _U32.pack(count)
    return bytes(out)


def _width(size: int) -> int:
    return 1 if size <= 0xFF else 2 if size <= 0xFFFF else 4


def _index(code: str, value: int) -> bytes:
    return struct.pack(f"<{code}", value)


def _indexes(code: str, values: list[int]) -> bytes:
    return struct.pack(f"<{len(values)}{code}", *values)


def _unit_indexes(code: str, units: list[str], text_index: Mapping[str, int]) -> bytes:
    """The index of each unit; a metric's scalars nearly always share one unit, which is
    then looked up once."""
    if units and units.count(units[0]) == len(units):
        return _indexes(code, [text_index[units[0]]] * len(units))
    return _indexes(code, list(map(text_index.__getitem__, units)))


def _bitmap(flags: Sequence[object]) -> bytes:
    """Bit i (of byte i // 8, least significant first) set where flags[i] is true."""
    if not flags:
        return b""
    # In C loops: the flags as the digits of a binary number, flag 0 the last digit.
    # (operator.truth, not bool: calling a type costs more than calling a function.)
    digits = bytes(map(operator.truth, flags)).translate(_BINARY_DIGITS)[::-1]
    return int(digits, 2).to_bytes((len(flags) + 7) // 8, "little")


_BINARY_DIGITS = bytes.maketrans(b"\x00\x01", b"01")


# ---- decoding ----


def summary_version(payload: bytes) -> int:
    """The layout version of a summary's bytes (SummaryError when they are none)."""
    if len(payload) < 6 or payload[:4] != _MAGIC:
        raise SummaryError("not a stook batch summary (no STKS header)")
    version: int = _U16.unpack_from(payload, 4)[0]
    return version


def _check_version(payload: bytes) -> None:
    version = summary_version(payload)
    if version > SUMMARY_VERSION:
        raise SummaryVersionError(
            f"batch summary version {version} is newer than this stook reads "
            f"(up to {SUMMARY_VERSION})"
        )
    if version < 1:
        raise SummaryError(f"batch summary version {version} does not exist")


def decode_summary(payload: bytes) -> BatchSummary:
    """The summary in `payload`; SummaryVersionError for a layout newer than this code's,
    SummaryError for bytes that are not a summary."""
    _check_version(payload)
    try:
        return _Decoder(payload).summary()
    except (struct.error, UnicodeDecodeError, IndexError, KeyError) as exc:
        raise SummaryError(f"batch summary is truncated or corrupt ({exc})") from None


def decode_summary_columns(payload: bytes) -> ColumnarSummary:
    """The summary in `payload` as columns, decoded straight into arrays (no object per
    job); the same errors as `decode_summary`."""
    _check_version(payload)
    try:
        return _Decoder(payload).columns()
    except (struct.error, UnicodeDecodeError, IndexError, KeyError, ValueError) as exc:
        if isinstance(exc, SummaryError):
            raise
        raise SummaryError(f"batch summary is truncated or corrupt ({exc})") from None


class _Decoder:
    def __init__(self, payload: bytes) -> None:
        self._buf = memoryview(payload)
        self._at = 6
        self._width: int = self._take(_U8)
        if self._width not in _WIDTH_CODES:
            raise SummaryError(f"batch summary index width {self._width} is not 1, 2 or 4")
        self._code = _WIDTH_CODES[self._width]

    def _take(self, shape: struct.Struct) -> int:
        (value,) = shape.unpack_from(self._buf, self._at)
        self._at += shape.size
        return int(value)

    def _bytes(self, size: int) -> bytes:
        end = self._at + size
        if end > len(self._buf):
            raise SummaryError("batch summary is truncated")
        chunk = bytes(self._buf[self._at : end])
        self._at = end
        return chunk

    def _indexes(self, count: int) -> tuple[int, ...]:
        values = struct.unpack_from(f"<{count}{self._code}", self._buf, self._at)
        self._at += count * self._width
        return values

    def _bits(self, count: int) -> list[bool]:
        raw = self._bytes((count + 7) // 8)
        return [bool(raw[i >> 3] >> (i & 7) & 1) for i in range(count)]

    def _array(self, count: int, dtype: str) -> np.ndarray:
        import numpy as np

        size = count * np.dtype(dtype).itemsize
        if self._at + size > len(self._buf):
            raise SummaryError("batch summary is truncated")
        out = np.frombuffer(self._buf, dtype=dtype, count=count, offset=self._at).copy()
        self._at += size
        return out

    def _bit_array(self, count: int) -> np.ndarray:
        import numpy as np

        raw = np.frombuffer(self._bytes((count + 7) // 8), dtype=np.uint8)
        flags: np.ndarray = np.unpackbits(raw, count=count, bitorder="little").astype(bool)
        return flags

    def _head(self) -> tuple[list[str], list[tuple[str, uuid.UUID | None]]]:
        texts = [self._bytes(self._take(_U32)).decode() for _ in range(self._take(_U32))]
        experiences: list[tuple[str, uuid.UUID | None]] = []
        for _ in range(self._take(_U32)):
            has_id = self._take(_U8)
            id_bytes = self._bytes(16)
            name = texts[self._indexes(1)[0]]
            experiences.append((name, uuid.UUID(bytes=id_bytes) if has_id else None))
        return texts, experiences

    def _statuses(self, texts: list[str]) -> dict[str, int]:
        statuses: dict[str, int] = {}
        for _ in range(self._take(_U32)):
            status = texts[self._indexes(1)[0]]
            statuses[status] = self._take(_U32)
        if self._at != len(self._buf):
            raise SummaryError("batch summary has bytes past its end")
        return statuses

    def columns(self) -> ColumnarSummary:
        import numpy as np

        index = f"<u{self._width}"
        texts, experiences = self._head()
        n = self._take(_U32)
        ids = self._bytes(16 * n)
        job_experiences = self._array(n, index).astype(np.int64)
        if n and int(job_experiences.max()) >= len(experiences):
            raise SummaryError("batch summary names an experience it does not hold")
        job_statuses = self._array(n, index)
        used, status = np.unique(job_statuses, return_inverse=True)
        has_metrics = self._bit_array(n)
        scalars: dict[str, ScalarColumn] = {}
        for _ in range(self._take(_U32)):
            name = texts[self._indexes(1)[0]]
            present = np.flatnonzero(self._bit_array(n))
            values = self._array(len(present), "<f8").astype(np.float64)
            units = self._array(len(present), index)
            if len(present):
                scalars[name] = ScalarColumn(present.astype(np.int64), values, texts[units[0]])
        statuses = self._statuses(texts)
        columns = JobColumns(
            job_ids=ids,
            experiences=tuple(experiences),
            experience=job_experiences,
            statuses=tuple(texts[i] for i in used.tolist()),
            status=status.reshape(-1).astype(np.int64),
            scalars=dict(sorted(scalars.items())),
            metric_statuses=dict(sorted(statuses.items())),
        )
        return ColumnarSummary(columns, int(has_metrics.sum()))

    def summary(self) -> BatchSummary:
        texts, experiences = self._head()
        n = self._take(_U32)
        ids = self._bytes(16 * n)
        job_experiences = self._indexes(n)
        job_statuses = self._indexes(n)
        has_metrics = self._bits(n)
        scalars: list[dict[str, tuple[float, str]]] = [{} for _ in range(n)]
        for _ in range(self._take(_U32)):
            name = texts[self._indexes(1)[0]]
            present = [i for i, flag in enumerate(self._bits(n)) if flag]
            values = struct.unpack_from(f"<{len(present)}d", self._buf, self._at)
            self._at += 8 * len(present)
            units = self._indexes(len(present))
            for job, value, unit in zip(present, values, units, strict=True):
                scalars[job][name] = (value, texts[unit])
        statuses = self._statuses(texts)
        jobs = tuple(
            SummaryJob(
                uuid.UUID(bytes=ids[16 * i : 16 * i + 16]),
                experiences[job_experiences[i]][0],
                texts[job_statuses[i]],
                experiences[job_experiences[i]][1],
                has_metrics[i],
                scalars[i],
            )
            for i in range(n)
        )
        return BatchSummary(jobs, statuses)


# ---- as metrics data ----


def summary_text(summary: BatchSummary) -> str:
    """The summary as the one element of its STRING metrics data (base64: protobuf
    strings must be UTF-8)."""
    return _as_text(encode_summary(summary))


def _as_text(payload: bytes) -> str:
    return base64.b64encode(payload).decode("ascii")


def summary_from_text(text: str) -> BatchSummary:
    return decode_summary(_payload(text))


def _payload(text: str) -> bytes:
    try:
        return base64.b64decode(text.encode("ascii"), validate=True)
    except (ValueError, UnicodeEncodeError):
        raise SummaryError("batch summary is not base64 text") from None


def summary_from_data(view: MetricsDataView) -> BatchSummary:
    """The summary held by its metrics data (read with `read_metrics_data`)."""
    return summary_from_text(_summary_string(view))


def summary_columns_from_data(view: MetricsDataView) -> ColumnarSummary:
    """The summary held by its metrics data, as columns (`decode_summary_columns`)."""
    return decode_summary_columns(_payload(_summary_string(view)))


def _summary_string(view: MetricsDataView) -> str:
    values = view.values() if view.kind is not None and not view.per_category else ()
    if len(values) != 1 or not isinstance(values[0], str):
        raise SummaryError(f"metrics data {view.name!r} does not hold one summary string")
    return values[0]


# ---- written by batch mode ----


@dataclass
class BatchSummaryWriter(Aggregation[JobRecord]):
    """Folds every job of a batch into its `BatchSummary` and writes it as metrics data
    referenced by no metric. It reads every SCALAR (`every_scalar`), so that the summary
    holds what a report's per-job listings would give, whatever the report asks for.

    `skip(reason)` withholds the summary (a job whose metrics could not be read): a
    report then lists that batch's jobs itself rather than trust an incomplete summary.
    """

    name: str = SUMMARY_DATA_NAME
    # A row per job (see `_Row`), its scalars the record's own `Scalar`s: a `SummaryJob`
    # and a dict of pairs per job cost more than the rest of the job's fold.
    jobs: dict[uuid.UUID, _Row] = field(default_factory=dict, init=False)
    statuses: Counter[str] = field(default_factory=Counter, init=False)
    # Jobs' metric statuses, counted COUNT_BATCH jobs at a time (see `MetricStatusCounts`).
    waiting: list[Sequence[str]] = field(default_factory=list, init=False)
    skipped: str | None = field(default=None, init=False)

    def needs(self) -> Needs:
        return Needs(every_scalar=True)

    def _count_waiting(self) -> None:
        if self.waiting:
            waiting, self.waiting = self.waiting, []
            self.statuses.update(chain.from_iterable(waiting))

    def update(self, record: JobRecord) -> None:
        self.jobs[record.job_id] = (
            record.job_id,
            record.experience_name,
            record.conflated_status,
            record.experience_id,
            bool(record.metric_statuses),
            record.scalars,
        )
        self.waiting.append(record.metric_statuses)
        if len(self.waiting) >= COUNT_BATCH:
            self._count_waiting()

    def merge(self, other: Self) -> None:
        self._count_waiting()
        other._count_waiting()
        self.jobs.update(other.jobs)
        self.statuses.update(other.statuses)
        self.skipped = self.skipped or other.skipped

    def __getstate__(self) -> dict[str, object]:
        """What travels between processes (see `Aggregation`): the jobs in the summary's
        own layout (~20 bytes a job plus 8 and an index per scalar) rather than a row, a
        UUID and a dict of `Scalar`s per job; it decodes to equal jobs."""
        self._count_waiting()
        state = dict(self.__dict__)
        state["jobs"] = _encode(self.jobs.values(), {}, _SCALAR_PARTS)
        return state

    def __setstate__(self, state: dict[str, object]) -> None:
        packed = state.pop("jobs")
        assert isinstance(packed, bytes)
        self.__dict__.update(state)
        self.jobs = {
            job.job_id: (
                job.job_id,
                job.experience_name,
                job.conflated_status,
                job.experience_id,
                job.has_metrics,
                {name: Scalar(value, unit) for name, (value, unit) in job.scalars.items()},
            )
            for job in decode_summary(packed).jobs
        }

    def skip(self, reason: str) -> None:
        self.skipped = reason

    def summary(self) -> BatchSummary:
        self._count_waiting()
        rows = sorted(self.jobs.values(), key=lambda row: row[0].bytes)
        return BatchSummary(
            tuple(
                SummaryJob(*row[:5], {name: (s.value, s.unit) for name, s in row[5].items()})
                for row in rows
            ),
            dict(sorted(self.statuses.items())),
        )

    def text(self) -> str:
        """`summary_text(self.summary())`, encoded from the rows (no `SummaryJob` each)."""
        self._count_waiting()
        return _as_text(_encode(self.jobs.values(), self.statuses, _SCALAR_PARTS))

    def finish(self, writer: MetricsWriter) -> None:
        if self.skipped is not None:
            return
        writer.add_data(strings(SUMMARY_DATA_NAME, [self.text()]))
