"""Jobs as columns: what aggregations reduce with numpy and C loops rather than job by job.

Report mode builds one `JobColumns` per batch, from the batch's summary or from its
per-job listings alike, so that both give the aggregations the same arrays. A report of
a million jobs then folds a thousand batches of arrays, not a million job objects. The
per-job views of `BatchRecord` (`jobs`, `job_scalars`, `job_metric_statuses`) are made
from the columns only when read (`JobSummaries`, `PooledScalars`, `StatusList`).

`values_by_name` turns jobs' scalars by name into one column per name, for the scalar
defaults and the batch summary, which read every job's scalars a metric at a time. With
``operator.methodcaller("get", name)`` (a bound method made and freed per job and name)
this was the larger part of either's cost; ``dict.get`` itself, mapped over the jobs,
costs a third.
"""

from __future__ import annotations

import uuid
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from itertools import repeat
from operator import methodcaller
from typing import TYPE_CHECKING, Any, TypeVar, overload

if TYPE_CHECKING:
    import numpy as np


_T = TypeVar("_T")
_NO_ID = bytes(16)


@dataclass(frozen=True, slots=True)
class JobSummary:
    """One job of a report's batch: what report aggregations read of it.

    `scalars` holds the job's SCALAR job metric values by name when the plan asks for job
    metrics (`Needs.job_metrics`), as `BatchRecord.job_scalars` pools them; else empty.
    """

    job_id: uuid.UUID
    experience_name: str
    conflated_status: str
    experience_id: uuid.UUID | None = None
    scalars: Mapping[str, float] = field(default_factory=dict, hash=False)


def experience_key(name: str, experience_id: uuid.UUID | None) -> tuple[str, bytes]:
    """How a batch's experiences are ordered: by name, then ID bytes (none first)."""
    return name, experience_id.bytes if experience_id is not None else _NO_ID


@dataclass(frozen=True, slots=True, eq=False)
class ScalarColumn:
    """One SCALAR job metric across a batch's jobs: the positions (in `JobColumns` order)
    of the jobs that have it, ascending, their values, and the first such job's unit."""

    jobs: np.ndarray
    values: np.ndarray
    unit: str = ""

    def __eq__(self, other: object) -> bool:
        import numpy as np

        return (
            isinstance(other, ScalarColumn)
            and self.unit == other.unit
            and np.array_equal(self.jobs, other.jobs)
            and np.array_equal(self.values, other.values, equal_nan=True)
        )

    __hash__ = None  # type: ignore[assignment]


@dataclass(frozen=True, slots=True, eq=False)
class JobColumns:
    """A batch's jobs, sorted by job ID, as columns.

    `job_ids` holds 16 bytes per job; `experience` and `status` index, per job, into
    `experiences` (distinct (name, ID) pairs, sorted by `experience_key`) and `statuses`
    (distinct conflated statuses, sorted). `scalars` holds each SCALAR job metric's
    column by name (sorted) and `metric_statuses` the count of each job metric status
    (sorted); both are empty when the report reads no job metrics. `pooled`, when not
    None, overrides a metric's values across jobs (`BatchRecord.job_scalars` given
    apart from its jobs); otherwise they are the column's.
    """

    job_ids: bytes
    experiences: tuple[tuple[str, uuid.UUID | None], ...]
    experience: np.ndarray
    statuses: tuple[str, ...]
    status: np.ndarray
    scalars: Mapping[str, ScalarColumn] = field(default_factory=dict)
    metric_statuses: Mapping[str, int] = field(default_factory=dict)
    pooled: Mapping[str, np.ndarray] | None = None

    def __len__(self) -> int:
        return len(self.job_ids) // 16

    def __eq__(self, other: object) -> bool:
        import numpy as np

        if not isinstance(other, JobColumns):
            return NotImplemented
        mine, theirs = self.pooled or {}, other.pooled or {}
        return (
            self.job_ids == other.job_ids
            and self.experiences == other.experiences
            and np.array_equal(self.experience, other.experience)
            and self.statuses == other.statuses
            and np.array_equal(self.status, other.status)
            and dict(self.scalars) == dict(other.scalars)
            and list(self.metric_statuses.items()) == list(other.metric_statuses.items())
            and mine.keys() == theirs.keys()
            and all(np.array_equal(mine[k], theirs[k], equal_nan=True) for k in mine)
        )

    __hash__ = None  # type: ignore[assignment]

    def experience_names(self) -> tuple[tuple[str, ...], np.ndarray]:
        """The distinct experience names (sorted) and, per job, the index of its name:
        report aggregations group jobs by experience name."""
        import numpy as np

        names = tuple(sorted({name for name, _ in self.experiences}))
        at = {name: i for i, name in enumerate(names)}
        codes = np.asarray([at[name] for name, _ in self.experiences], dtype=np.int64)
        return names, codes[self.experience] if len(codes) else np.zeros(0, dtype=np.int64)

    def values(self, metric: str) -> np.ndarray:
        """The metric's values across the batch's jobs (job-ID order, or as `pooled`)."""
        if self.pooled is not None:
            return self.pooled[metric]
        return self.scalars[metric].values

    def metrics(self) -> list[str]:
        """The names of the SCALAR job metrics with values (sorted)."""
        return sorted(self.pooled if self.pooled is not None else self.scalars)

    def units(self) -> dict[str, str]:
        return {name: column.unit for name, column in self.scalars.items()}

    # ---- built ----

    @classmethod
    def build(
        cls,
        jobs: Sequence[JobSummary],
        scalars: Sequence[Mapping[str, tuple[float, str]]],
        metric_statuses: Mapping[str, int],
    ) -> JobColumns:
        """A batch's columns from its jobs, each job's SCALARs ((value, unit) by name,
        one mapping per job, in the order of `jobs`) and its job metric statuses'
        counts. Jobs are put in job-ID order (equal IDs keep their order)."""
        import numpy as np

        order = sorted(range(len(jobs)), key=lambda i: jobs[i].job_id.bytes)
        ordered = [jobs[i] for i in order]
        experiences = sorted(
            {(j.experience_name, j.experience_id) for j in ordered},
            key=lambda e: experience_key(*e),
        )
        experience_at = {e: i for i, e in enumerate(experiences)}
        statuses = sorted({j.conflated_status for j in ordered})
        status_at = {s: i for i, s in enumerate(statuses)}
        found: dict[str, tuple[list[int], list[float], str]] = {}
        for position, i in enumerate(order):
            for name, (value, unit) in scalars[i].items():
                column = found.setdefault(name, ([], [], unit))
                column[0].append(position)
                column[1].append(value)
        return cls(
            job_ids=b"".join(j.job_id.bytes for j in ordered),
            experiences=tuple(experiences),
            experience=np.asarray(
                [experience_at[(j.experience_name, j.experience_id)] for j in ordered],
                dtype=np.int64,
            ),
            statuses=tuple(statuses),
            status=np.asarray([status_at[j.conflated_status] for j in ordered], dtype=np.int64),
            scalars={
                name: ScalarColumn(
                    np.asarray(positions, dtype=np.int64), np.asarray(vals, dtype=np.float64), unit
                )
                for name, (positions, vals, unit) in sorted(found.items())
            },
            metric_statuses=dict(sorted(metric_statuses.items())),
        )

    # ---- per-job views, made when read ----

    def job_id(self, position: int) -> uuid.UUID:
        return uuid.UUID(bytes=self.job_ids[16 * position : 16 * position + 16])

    def job_summaries(self) -> list[JobSummary]:
        """One `JobSummary` per job, with its scalar values, in job-ID order."""
        scalars: list[dict[str, float]] = [{} for _ in range(len(self))]
        for name, column in self.scalars.items():
            for position, value in zip(column.jobs.tolist(), column.values.tolist(), strict=True):
                scalars[position][name] = value
        experiences = self.experiences
        statuses = self.statuses
        return [
            JobSummary(
                self.job_id(i),
                experiences[e][0],
                statuses[s],
                experiences[e][1],
                scalars[i],
            )
            for i, (e, s) in enumerate(
                zip(self.experience.tolist(), self.status.tolist(), strict=True)
            )
        ]


class _LazyList(Sequence[_T]):
    """A sequence whose items are made on first read (`_make`), then kept; equal to any
    sequence (but a string) with the same items, as the list it stands for would be."""

    __slots__ = ("_items",)

    def __init__(self) -> None:
        self._items: list[_T] | None = None

    def _make(self) -> list[_T]:
        raise NotImplementedError

    def _list(self) -> list[_T]:
        if self._items is None:
            self._items = self._make()
        return self._items

    def __len__(self) -> int:
        return len(self._list())

    @overload
    def __getitem__(self, index: int) -> _T: ...
    @overload
    def __getitem__(self, index: slice) -> Sequence[_T]: ...
    def __getitem__(self, index: int | slice) -> _T | Sequence[_T]:
        return self._list()[index]

    def __iter__(self) -> Iterator[_T]:
        return iter(self._list())

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Sequence) and not isinstance(other, str):
            return list(self) == list(other)
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]


class JobSummaries(_LazyList[JobSummary]):
    """`BatchRecord.jobs` of a record built from columns: the `JobSummary` objects are
    made on first read, so a report whose aggregations read only columns never makes
    them."""

    __slots__ = ("_columns",)

    def __init__(self, columns: JobColumns) -> None:
        super().__init__()
        self._columns = columns

    def _make(self) -> list[JobSummary]:
        return self._columns.job_summaries()

    def __len__(self) -> int:
        return len(self._columns)

    def __repr__(self) -> str:
        return f"JobSummaries({len(self)} jobs)"


class PooledScalars(Mapping[str, Sequence[float]]):
    """`BatchRecord.job_scalars` of a record built from columns: each metric's values
    across the jobs, sorted, made into a list on first read."""

    __slots__ = ("_columns", "_made")

    def __init__(self, columns: JobColumns) -> None:
        self._columns = columns
        self._made: dict[str, list[float]] = {}

    def __getitem__(self, name: str) -> list[float]:
        if name not in self._made:
            if name not in self._columns.scalars:
                raise KeyError(name)
            values: list[float] = self._columns.scalars[name].values.tolist()
            self._made[name] = sorted(values)
        return self._made[name]

    def __iter__(self) -> Iterator[str]:
        return iter(self._columns.scalars)

    def __len__(self) -> int:
        return len(self._columns.scalars)

    def __eq__(self, other: object) -> bool:
        if isinstance(other, Mapping):
            return dict(self) == dict(other)
        return NotImplemented

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"PooledScalars({list(self)})"


class StatusList(_LazyList[str]):
    """`BatchRecord.job_metric_statuses` of a record built from columns: every job
    metric's status, sorted, expanded from the counts on first read."""

    __slots__ = ("_counts",)

    def __init__(self, counts: Mapping[str, int]) -> None:
        super().__init__()
        self._counts = counts

    def _make(self) -> list[str]:
        return [s for s, n in sorted(self._counts.items()) for _ in range(n)]

    def __len__(self) -> int:
        return sum(self._counts.values())

    def __repr__(self) -> str:
        return f"StatusList({dict(self._counts)})"


def columns_of(
    jobs: Sequence[JobSummary],
    job_scalars: Mapping[str, Sequence[float]],
    job_metric_statuses: Sequence[str],
) -> JobColumns:
    """The columns of a record built from per-job fields (`BatchRecord.job_columns`):
    the scalars per job from each `JobSummary`, the values across jobs as given."""
    from collections import Counter

    import numpy as np

    built = JobColumns.build(
        jobs,
        [{n: (v, "") for n, v in j.scalars.items()} for j in jobs],
        Counter(job_metric_statuses),
    )
    pooled = {
        name: np.asarray(list(values), dtype=np.float64)
        for name, values in sorted(job_scalars.items())
    }
    return JobColumns(
        built.job_ids,
        built.experiences,
        built.experience,
        built.statuses,
        built.status,
        built.scalars,
        built.metric_statuses,
        pooled,
    )


_V = TypeVar("_V")
_DICT_GET: Any = dict.get


def values_by_name(jobs: Sequence[Mapping[str, _V]], names: Iterable[str]) -> list[list[_V | None]]:
    """Per name, each job's value of it (None for a job without it), in the jobs' order.

    Plain dicts (what a fetch hands over) are read with ``dict.get``; any other mapping,
    a dict subclass too (it may have a `get` of its own), through its own ``get``.
    """
    if set(map(type, jobs)) <= {dict}:
        count = len(jobs)
        return [list(map(_DICT_GET, jobs, repeat(name, count))) for name in names]
    return [list(map(methodcaller("get", name), jobs)) for name in names]
