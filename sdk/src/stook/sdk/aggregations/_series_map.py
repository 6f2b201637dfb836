"""A job's double series by data name, each converted to polars only when asked for.

A fetch hands every job's plain double data to its aggregations as `JobRecord.series`.
Building a polars Series per job cost more than some aggregations' whole update (the
merged histogram bins the values with numpy), so the series are made on first access
and kept; `values_of` gives the same values as a numpy array without polars, and
`packed_of` as their little-endian float64 bytes.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Iterator, Mapping
from typing import TYPE_CHECKING, Any

from stook.sdk._enums import SeriesKind

if TYPE_CHECKING:
    import numpy as np
    import polars as pl

    from stook.proto import metrics_pb2 as pb
    from stook.sdk._views import MetricsDataView


_DOUBLE = SeriesKind.DOUBLE  # an enum member read off its class costs a lookup


class SeriesByName(Mapping[str, "pl.Series"]):
    """Data name -> `MetricsDataView.series` of plain double data, made on first access.

    Reads like the dict of those series it stands for (iteration in the order given);
    batch mode hands each job's `JobRecord.series` over as one. Every view must be of
    plain (not per-category) double data (ValueError otherwise). An aggregation that
    reduces the values with numpy can take them with `values_of` instead, and then no
    polars Series is made for it.
    """

    __slots__ = ("_made", "_views")

    def __init__(self, views: Mapping[str, MetricsDataView]) -> None:
        for name, view in views.items():
            if view.kind is not _DOUBLE or view.per_category:
                raise ValueError(f"metrics data {name!r} is not a plain double series")
        self._views = views
        self._made: dict[str, pl.Series] = {}

    def __getitem__(self, name: str) -> pl.Series:
        made = self._made.get(name)
        if made is None:
            made = self._made[name] = self._views[name].series()
        return made

    def __iter__(self) -> Iterator[str]:
        return iter(self._views)

    def __len__(self) -> int:
        return len(self._views)

    def __contains__(self, name: object) -> bool:
        return name in self._views

    def __repr__(self) -> str:
        return repr(dict(self.items()))

    def values_of(self, name: str) -> np.ndarray[Any, np.dtype[np.float64]] | None:
        """The values of `name` as a read-only float64 array (None without such data),
        bit for bit the series' values, without a polars Series."""
        view = self._views.get(name)
        if view is None:
            return None
        return _doubles_array()(view.raw.series.doubles)

    def packed_of(self, name: str) -> bytes | None:
        """The values of `name` as little-endian float64 bytes (None without such data),
        bit for bit the series' values: for an aggregation that joins many jobs' values
        into one array, rather than make an array per job."""
        values = self.values_of(name)
        return None if values is None else values.astype("<f8", copy=False).tobytes()


@functools.cache
def _doubles_array() -> Callable[[pb.DoubleSeries], np.ndarray[Any, np.dtype[np.float64]]]:
    """`stook.sdk._series.doubles_array` (with numpy and polars), imported on first use:
    an import statement per job cost ~4 % of a job's decode+fold path (callgrind)."""
    from stook.sdk._series import doubles_array

    return doubles_array
