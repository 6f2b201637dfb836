"""The aggregation protocol: fold jobs in one at a time, merge partial states, write metrics."""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Generic, Self, TypeVar

from stook.sdk.aggregations._record import BatchRecord, JobRecord

if TYPE_CHECKING:
    # The writer (and protobuf with it) only once an aggregation writes its metrics:
    # `stook run` builds its aggregations before its first request.
    from stook.sdk._writer import MetricsWriter


@dataclass(frozen=True, slots=True)
class Needs:
    """What an aggregation reads, so that the fetcher downloads no more than that.

    Scalars, job parameters and the job's facts come with the listings at no extra cost.
    Each name in `data` costs a download per job that has it (any kind of metrics data:
    doubles, strings, statuses, timestamps, UUIDs, indexed or per category); each name in
    `metrics` costs the job's metric blob plus the blobs of the data it references, and
    `every_metric` asks for every metric and metrics data of every job (the load of
    ReSim's own fetcher). `events` costs one listing per job, `experience_tags` one per
    experience (not per job). Data in `data` comes without its index data unless named in
    `data_with_index` too (labels of a bar chart's values, timestamps of a series): one
    more download per job whose data is indexed. In report mode, `job_metrics` asks for
    the metric listing of every job of every batch (one request per job).

    `scalars` names the SCALAR metrics an aggregation reads, and `every_scalar` says it
    reads all of them, whatever their names. The API may list a scalar without its value
    (`value: null`); the value is then downloaded from the metric itself, but only for the
    scalars declared here, so a scalar that no aggregation declares may be missing from
    `JobRecord.scalars` when the API lists it without a value.
    """

    scalars: frozenset[str] = frozenset()
    data: frozenset[str] = frozenset()
    job_metrics: bool = False
    every_scalar: bool = False
    metrics: frozenset[str] = frozenset()
    every_metric: bool = False
    events: bool = False
    experience_tags: bool = False
    data_with_index: frozenset[str] = frozenset()

    def __or__(self, other: Needs) -> Needs:
        return Needs(
            scalars=self.scalars | other.scalars,
            data=self.data | other.data,
            job_metrics=self.job_metrics or other.job_metrics,
            every_scalar=self.every_scalar or other.every_scalar,
            metrics=self.metrics | other.metrics,
            every_metric=self.every_metric or other.every_metric,
            events=self.events or other.events,
            experience_tags=self.experience_tags or other.experience_tags,
            data_with_index=self.data_with_index | other.data_with_index,
        )

    def wants_metric(self, name: str) -> bool:
        """Whether an aggregation reads the job metric `name` with the data it references."""
        return self.every_metric or name in self.metrics

    def wants_scalar(self, name: str) -> bool:
        """Whether an aggregation reads the SCALAR metric `name`."""
        return self.every_scalar or name in self.scalars


R = TypeVar("R")


class Aggregation(ABC, Generic[R]):
    """A metric computed as a mergeable partial state over records: the jobs of a batch
    (`JobRecord`, batch mode) or the batches of a report (`BatchRecord`, report mode).

    Subclasses are dataclasses: their init fields are the configuration (what the
    TOML table holds) and their non-init fields the partial state. `update` folds in
    one record, `merge` folds in another partial state of the same configuration (built
    from other records), and `finish` writes the result. Folding records into several
    partials and merging them must give what folding them all into one gives, in any
    order.

    Partial states travel between processes: the processes and Ray engines fold each
    shard in a worker and pickle its partial back to be merged. So a partial must pickle
    (no lambdas, locks, open files or generators in its state) and unpickle to one that
    updates, merges and finishes as the original would; `stook.sdk.testing.check_merge_laws`
    checks both. Keep what is pickled compact: counts where the output needs only counts,
    per-record values packed (``array("d")``, 8 bytes each) where it needs the values;
    ``__getstate__`` / ``__setstate__`` may pack a state that is cheaper to update unpacked.
    """

    #: the name of the first metric it writes; used in errors and logs
    name: str

    def needs(self) -> Needs:
        return Needs()

    @abstractmethod
    def update(self, record: R) -> None: ...

    @abstractmethod
    def merge(self, other: Self) -> None: ...

    @abstractmethod
    def finish(self, writer: MetricsWriter) -> None: ...

    def fresh(self) -> Self:
        """An empty partial state with this one's configuration."""
        return dataclasses.replace(self)  # type: ignore[type-var]


#: an aggregation over the jobs of a batch (batch mode)
BatchAggregation = Aggregation[JobRecord]
#: an aggregation over the batches of a report (report mode)
ReportAggregation = Aggregation[BatchRecord]
