"""The aggregation protocol: fold jobs in one at a time, merge partial states, write metrics."""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Self

from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._record import JobRecord


@dataclass(frozen=True, slots=True)
class Needs:
    """What an aggregation reads, so that the fetcher downloads no more than that.

    Scalars come with the job listing at no extra cost; each name in `data` costs a
    download per job that has it.
    """

    scalars: frozenset[str] = frozenset()
    data: frozenset[str] = frozenset()

    def __or__(self, other: Needs) -> Needs:
        return Needs(self.scalars | other.scalars, self.data | other.data)


class Aggregation(ABC):
    """A batch metric computed as a mergeable partial state.

    Subclasses are dataclasses: their init fields are the configuration (what the
    TOML table holds) and their non-init fields the partial state. `update` folds in
    one job, `merge` folds in another partial state of the same configuration (built
    from other jobs), and `finish` writes the result. Folding jobs into several
    partials and merging them must give what folding them all into one gives.
    """

    #: the name of the first metric it writes; used in errors and logs
    name: str

    def needs(self) -> Needs:
        return Needs()

    @abstractmethod
    def update(self, job: JobRecord) -> None: ...

    @abstractmethod
    def merge(self, other: Self) -> None: ...

    @abstractmethod
    def finish(self, writer: MetricsWriter) -> None: ...

    def fresh(self) -> Self:
        """An empty partial state with this one's configuration."""
        return dataclasses.replace(self)  # type: ignore[type-var]
