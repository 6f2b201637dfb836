"""Per-batch reductions of a batch's job columns (`JobColumns`): which jobs have a status
in a set, and counts per experience, with numpy instead of a loop per job."""

from __future__ import annotations

from collections.abc import Collection
from typing import TYPE_CHECKING

from stook.sdk.aggregations._columns import JobColumns

if TYPE_CHECKING:
    import numpy as np


def status_in(columns: JobColumns, statuses: Collection[str]) -> np.ndarray:
    """Per job: is its conflated status one of `statuses`?"""
    import numpy as np

    table = np.asarray([s in statuses for s in columns.statuses], dtype=bool)
    found: np.ndarray = table[columns.status] if len(table) else np.zeros(len(columns), bool)
    return found


def first_seen(codes: np.ndarray) -> list[int]:
    """The distinct codes in the order they first appear (as a loop over the jobs would
    meet them)."""
    import numpy as np

    distinct, first = np.unique(codes, return_index=True)
    ordered: list[int] = distinct[np.argsort(first)].tolist()
    return ordered


def counts(codes: np.ndarray, size: int) -> list[int]:
    """How many times each code 0..size-1 occurs."""
    import numpy as np

    found: list[int] = np.bincount(codes, minlength=size).tolist()
    return found
