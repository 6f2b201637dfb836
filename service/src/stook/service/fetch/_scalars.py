"""The SCALAR metrics of a metric listing, by name, including those listed without a value.

The spec makes a metric's ``value`` nullable: the API may list a SCALAR with ``value: null``
and keep the number only in the serialized ``Metric`` message at ``metricURL``. Reading that
message costs a download per metric, so it is done only for the null scalars the
aggregation plan reads (``Needs.wants_scalar``); scalars listed with a value cost nothing.
A null scalar whose message holds no value either is absent for that job, said at debug
level, never an error.
"""

from __future__ import annotations

import asyncio
from collections.abc import Awaitable, Callable, Sequence

import structlog

from stook.sdk.aggregations import Scalar
from stook.service.api import ApiMetric, ApiMetricType, StorageClient
from stook.service.fetch._presigned import fetch_listed

__all__ = ["is_scalar", "read_scalar_values", "read_scalars"]

log = structlog.get_logger("stook.fetch")

Relist = Callable[[], Awaitable[Sequence[ApiMetric]]]


def is_scalar(metric: ApiMetric) -> bool:
    """A named SCALAR metric that is not an event's: what aggregations get by name."""
    return metric.type == ApiMetricType.SCALAR and not metric.event_metric and bool(metric.name)


async def read_scalars(
    storage: StorageClient,
    metrics: Sequence[ApiMetric],
    wanted: Callable[[str], bool],
    *,
    source: str,
    relist: Relist,
) -> dict[str, Scalar]:
    """Every named SCALAR of `metrics` that has a value, by name (the last of a name wins).

    Values listed as null are read from the metric's message when `wanted(name)` (an
    aggregation reads that scalar); `relist` lists the metrics again when a presigned URL
    has expired.
    """
    found: list[tuple[str, Scalar | None]] = []
    blobs: list[Awaitable[Scalar | None]] = []
    for metric in metrics:
        if not is_scalar(metric):
            continue
        if metric.value is not None:
            found.append((metric.name, Scalar(metric.value, metric.unit or "", str(metric.status))))
        elif wanted(metric.name):
            found.append((metric.name, None))
            blobs.append(_from_message(storage, metric, source=source, relist=relist))
        else:
            log.debug(
                "scalar listed without a value; no aggregation reads it",
                source=source,
                metric=metric.name,
            )
    resolved = iter(await asyncio.gather(*blobs)) if blobs else iter(())
    scalars: dict[str, Scalar] = {}
    for name, scalar in found:
        value = scalar if scalar is not None else next(resolved)
        if value is not None:
            scalars[name] = value
    return scalars


async def read_scalar_values(
    storage: StorageClient,
    metrics: Sequence[ApiMetric],
    wanted: Callable[[str], bool],
    *,
    names: set[str],
    source: Callable[[], str],
    relist: Relist,
) -> dict[str, tuple[float, str]]:
    """As `read_scalars`, each scalar as (value, unit); adds every named SCALAR listed,
    with a value or not, to `names` once the values are read.

    One pass over the listing when every scalar is listed with its value (what report
    mode reads per job, thousands of times); `source` is made only when a message is read.
    """
    listed: list[str] = []
    values: dict[str, tuple[float, str]] = {}
    for metric in metrics:
        if metric.type != ApiMetricType.SCALAR or metric.event_metric or not metric.name:
            continue
        if metric.value is None:
            break
        listed.append(metric.name)
        values[metric.name] = (metric.value, metric.unit or "")
    else:
        names.update(listed)
        return values
    scalars = await read_scalars(storage, metrics, wanted, source=source(), relist=relist)
    names.update(m.name for m in metrics if is_scalar(m))
    return {name: (scalar.value, scalar.unit) for name, scalar in scalars.items()}


async def _from_message(
    storage: StorageClient, metric: ApiMetric, *, source: str, relist: Relist
) -> Scalar | None:
    where = f"{source} / metric {metric.name!r}"
    payload, metric = await fetch_listed(
        storage,
        metric,
        url_of=lambda m: m.metric_url,
        id_of=lambda m: m.metric_id,
        relist=relist,
        source=where,
    )
    if payload is None:
        log.debug("scalar listed without a value or a URL; absent", source=where)
        return None
    # A message that cannot be read is invalid metrics data (ReadError, exit code 4), as
    # for a metrics-data download. The reader (and protobuf) only for a scalar listed
    # without its value: most runs never need them.
    from stook.sdk import read_metric

    view = read_metric(payload, source=where)
    if view.value is None:
        log.debug("scalar has no value in its listing or its message; absent", source=where)
        return None
    return Scalar(view.value, metric.unit or view.unit or "", str(metric.status))
