"""Jobs' scalars by name turned into one column per name, in C loops.

The scalar defaults and the batch summary both read every job's scalars a metric at a
time. With ``operator.methodcaller("get", name)`` (a bound method made and freed per job
and name) this was the larger part of either's cost; ``dict.get`` itself, mapped over the
jobs, costs a third.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping, Sequence
from itertools import repeat
from operator import methodcaller
from typing import Any, TypeVar

__all__ = ["columns_of"]

_V = TypeVar("_V")
_DICT_GET: Any = dict.get


def columns_of(jobs: Sequence[Mapping[str, _V]], names: Iterable[str]) -> list[list[_V | None]]:
    """Per name, each job's value of it (None for a job without it), in the jobs' order.

    Plain dicts (what a fetch hands over) are read with ``dict.get``; any other mapping,
    a dict subclass too (it may have a `get` of its own), through its own ``get``.
    """
    if set(map(type, jobs)) <= {dict}:
        count = len(jobs)
        return [list(map(_DICT_GET, jobs, repeat(name, count))) for name in names]
    return [list(map(methodcaller("get", name), jobs)) for name in names]
