"""One job's blobs as the plan asks for them: metrics data by name, job metrics with their data.

`Needs.data` names metrics data; `Needs.metrics` (or `every_metric`) names job metrics,
each of which costs its ``Metric`` blob plus the blobs of the metrics data it references
(by the listing's ``dataIDs`` and the message's own references), and of their index data.
Every blob is downloaded at most once per job, however many of the plan's wants share it,
and nothing the plan did not ask for is downloaded.
"""

from __future__ import annotations

import asyncio
import functools
import uuid
from collections.abc import Awaitable, Callable, Collection, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Final, TypeVar

import structlog

from stook.proto import metrics_pb2 as pb
from stook.sdk import (
    JobMetricsView,
    MetricsDataView,
    MetricView,
    ReadError,
    SeriesKind,
    parse_job_metrics,
    parse_metrics_data,
    read_metric,
    read_metrics_data,
)
from stook.sdk.aggregations import Needs, SeriesByName
from stook.service.api import ApiMetric, ApiMetricsData, PresignedUrlExpiredError, StorageClient
from stook.service.fetch._errors import InvalidDataError
from stook.service.fetch._presigned import fetch_listed, fetch_relisted

if TYPE_CHECKING:
    import polars as pl

__all__ = ["InvalidDataError", "JobBlobs", "JobBlobsResult", "decode_values"]

log = structlog.get_logger("stook.fetch")
_T = TypeVar("_T")


@dataclass(frozen=True, slots=True)
class JobBlobsResult:
    """What a job's blobs give its record."""

    data: Mapping[str, MetricsDataView]
    series: Mapping[str, pl.Series]
    job_metrics: JobMetricsView | None


_DOUBLE: Final = SeriesKind.DOUBLE  # an enum member read off its class costs a lookup


class JobBlobs:
    """Downloads one job's wanted blobs; `metrics` and `data` are the job's listings.

    `relist_metrics` and `relist_data` list them again when a presigned URL has expired.
    """

    def __init__(
        self,
        storage: StorageClient,
        job_id: uuid.UUID,
        needs: Needs,
        *,
        metrics: Sequence[ApiMetric],
        data: Sequence[ApiMetricsData],
        relist_metrics: Callable[[], Awaitable[Sequence[ApiMetric]]],
        relist_data: Callable[[], Awaitable[Sequence[ApiMetricsData]]],
        source: str | None = None,
    ) -> None:
        """`source` names the job in errors (``job <ID>``), when the caller has it already."""
        self._storage = storage
        self._job_id = job_id
        self._source = source
        self._needs = needs
        self._metrics = metrics
        self._data = data
        self._relist_metrics = relist_metrics
        self._relist_data = relist_data
        self._views: dict[uuid.UUID, MetricsDataView] = {}

    @functools.cached_property
    def _listed(self) -> dict[uuid.UUID, ApiMetricsData]:
        """The listed metrics data by ID; external files are in `_files`."""
        return {d.data_id: d for d in self._data if d.is_standard}

    @functools.cached_property
    def _files(self) -> dict[uuid.UUID, ApiMetricsData]:
        """The listed external files by ID (see `_file`)."""
        return {d.data_id: d for d in self._data if not d.is_standard}

    @property
    def wants_metrics(self) -> bool:
        return bool(self._needs.metrics) or self._needs.every_metric

    async def fetch(self) -> JobBlobsResult:
        needs = self._needs
        named = [d for d in self._data if d.name in needs.data and d.is_standard]
        wants_metrics = bool(needs.metrics) or needs.every_metric
        metric_views: Sequence[MetricView] = ()
        indexed: Collection[uuid.UUID] = ()
        if wants_metrics or needs.data_with_index:
            metric_views, indexed = await self._download_referenced(named)
            views = [self._views[item.data_id] for item in named]
        elif len(named) == 1:
            # The common plan, data by name alone, and one series a job: awaited in this
            # frame (see `_download`), and not kept by ID (a UUID hashes in Python code).
            views = [await self._download(named[0])]
        else:
            # Data by name alone: nothing else is downloaded.
            await self._download_all(named)
            views = [self._views[item.data_id] for item in named]
        data: dict[str, MetricsDataView] = {}
        doubles: dict[str, MetricsDataView] = {}
        for item, view in zip(named, views, strict=True):
            if indexed and item.data_id in indexed and view.index_id is not None:
                view = view.with_index(self._views[view.index_id])
            data[item.name] = view
            # Per-category data keeps its categories in `data`: no single series of it.
            # Made into polars Series only when an aggregation asks (see `SeriesByName`).
            if view.kind is _DOUBLE and not view.per_category:
                doubles[item.name] = view
        job_metrics = self._job_metrics(metric_views) if wants_metrics else None
        return JobBlobsResult(data, SeriesByName(doubles), job_metrics)

    async def _download_referenced(
        self, named: Sequence[ApiMetricsData]
    ) -> tuple[list[MetricView], list[uuid.UUID]]:
        """Download the `named` data, the wanted metrics, the data they reference and the
        index data of both (of the named data, those in `data_with_index` only): the
        metrics' views, and the named data to give with their index data."""
        wanted = self._wanted_metrics()
        # The data the listing says the wanted metrics reference go out with their Metric
        # blobs and the named data, in one round; what only a blob names follows.
        referenced: dict[uuid.UUID, str] = {}
        for listed in wanted:
            for data_id in listed.data_ids:
                referenced.setdefault(data_id, listed.name)
        if self._needs.every_metric:
            for data_id in self._listed:
                referenced.setdefault(data_id, "")
        first = {d.data_id: d for d in (*named, *self._resolve(referenced))}
        if wanted:
            metric_views, _ = await asyncio.gather(
                _gather(*(self._metric(m) for m in wanted)), self._download_all(first.values())
            )
        else:
            metric_views = []
            await self._download_all(first.values())
        # Data named in `data_with_index` comes with its index data, like a metric's data.
        indexed = [d.data_id for d in named if d.name in self._needs.data_with_index]
        if wanted or self._needs.every_metric or indexed:
            for listed, metric_view in zip(wanted, metric_views, strict=True):
                for data_id in metric_view.data_ids:
                    referenced.setdefault(data_id, listed.name)
            await self._download_all(self._resolve(referenced))
            # A metric's data comes with its index data (a series' timestamps), fetched
            # until none is missing. Data asked for by name alone does not, unless named
            # in `data_with_index`: its index would be a download no aggregation declared.
            pending = [*referenced, *indexed]
            while missing := {
                view.index_id: view.name
                for view in (self._views[i] for i in pending)
                if view.index_id is not None and view.index_id not in self._views
            }:
                await self._download_all(self._resolve(missing, index=True))
                pending = list(missing)
        return metric_views, indexed

    def _wanted_metrics(self) -> list[ApiMetric]:
        if not self.wants_metrics:
            return []  # the common plan: data by name only; no need to ask per metric
        wanted: list[ApiMetric] = []
        for metric in self._metrics:
            if not self._needs.wants_metric(metric.name):
                continue
            # Every metric means every metric that has a blob; a named one must have it.
            if metric.metric_url is None and metric.name not in self._needs.metrics:
                log.debug(
                    "metric listed without a URL; left out",
                    job_id=str(self._job_id),
                    metric=metric.name,
                )
                continue
            wanted.append(metric)
        return wanted

    def _where(self, what: str) -> str:
        if self._source is None:
            self._source = f"job {self._job_id}"
        return f"{self._source} / {what}"

    async def _metric(self, metric: ApiMetric) -> MetricView:
        source = self._where(f"metric {metric.name!r}")
        payload, _ = await fetch_listed(
            self._storage,
            metric,
            url_of=lambda m: m.metric_url,
            id_of=lambda m: m.metric_id,
            relist=self._relist_metrics,
            source=source,
        )
        if payload is None:
            raise InvalidDataError(f"could not read the Metric of {source}: it has no URL")
        try:
            return read_metric(payload, source=source)
        except ReadError as exc:
            raise InvalidDataError(str(exc)) from None

    def _resolve(
        self, ids: Mapping[uuid.UUID, str], *, index: bool = False
    ) -> list[ApiMetricsData]:
        """The listed data of `ids` not read yet; an ID the listing lacks is invalid data.

        An external file is read from its listing: its URL serves the file, not a message.
        """
        items: list[ApiMetricsData] = []
        for data_id, owner in ids.items():
            if data_id in self._views:
                continue
            if data_id in self._files:
                self._views[data_id] = self._file(self._files[data_id])
                continue
            item = self._listed.get(data_id)
            if item is None:
                if index:
                    what = f"metrics data {owner!r} has index data {data_id}"
                else:
                    what = f"metric {owner!r} references metrics data {data_id}"
                raise InvalidDataError(
                    f"{self._where(what)}, which the job's metrics data listing does not have"
                )
            items.append(item)
        return items

    async def _download_all(self, items: Iterable[ApiMetricsData]) -> None:
        todo = {i.data_id: i for i in items if i.data_id not in self._views}
        if len(todo) == 1:  # the common plan: one series a job, awaited with no gather
            ((data_id, item),) = todo.items()
            self._views[data_id] = await self._download(item)
            return
        if not todo:
            return
        views = await _gather(*(self._download(i) for i in todo.values()))
        self._views.update(zip(todo, views, strict=True))

    async def _download(self, item: ApiMetricsData) -> MetricsDataView:
        source = self._where(f"metrics data {item.name!r}")
        # `fetch_listed`, its first download awaited here: every resumption of a download
        # passes through each coroutine between the worker and the GET, and this is the
        # download of every job.
        payload = None
        if item.metrics_data_url is not None:
            try:
                payload = await self._storage.fetch_bytes(item.metrics_data_url)
            except PresignedUrlExpiredError as expired:
                payload, _ = await fetch_relisted(
                    self._storage,
                    item,
                    expired,
                    url_of=lambda d: d.metrics_data_url,
                    id_of=lambda d: d.data_id,
                    relist=self._relist_data,
                    source=source,
                )
        if payload is None:
            raise InvalidDataError(f"could not read MetricsData from {source}: it has no URL")
        try:
            return read_metrics_data(payload, source=source)
        except ReadError as exc:
            raise InvalidDataError(str(exc)) from None

    def _file(self, item: ApiMetricsData) -> MetricsDataView:
        """An external file (an image, a video) as the MetricsData that references it: its
        URL serves the file itself, not a message, and the file is no metrics data to
        download."""
        msg = pb.MetricsData(name=item.name, data_type=pb.EXTERNAL_FILE_DATA_TYPE)
        msg.metrics_data_id.id.data = str(item.data_id)
        msg.external_file.path = item.filename or item.name
        try:
            return parse_metrics_data(msg, source=self._where(f"metrics data {item.name!r}"))
        except ReadError as exc:
            raise InvalidDataError(str(exc)) from None

    def _job_metrics(self, metrics: Sequence[MetricView]) -> JobMetricsView:
        """The wanted metrics and the data they need as one JobMetrics, as a job wrote it."""
        msg = pb.JobMetrics()
        msg.job_id.id.data = str(self._job_id)
        msg.job_level_metrics.metrics.extend(view.raw for view in metrics)
        if self._needs.every_metric:
            keep: Collection[uuid.UUID] = self._views
        else:
            keep = _closure(metrics, self._views)
        # In listing order, so the view does not depend on the order downloads finished.
        msg.metrics_data.extend(self._views[d.data_id].raw for d in self._data if d.data_id in keep)
        try:
            return parse_job_metrics(msg, source=self._where("metrics"))
        except ReadError as exc:
            raise InvalidDataError(str(exc)) from None


def _closure(
    metrics: Sequence[MetricView], views: Mapping[uuid.UUID, MetricsDataView]
) -> set[uuid.UUID]:
    """The data IDs the metrics reference, with their index data."""
    keep: set[uuid.UUID] = set()
    todo = [data_id for view in metrics for data_id in view.data_ids]
    while todo:
        data_id = todo.pop()
        if data_id in keep or data_id not in views:
            continue
        keep.add(data_id)
        index = views[data_id].index_id
        if index is not None:
            todo.append(index)
    return keep


async def _gather(*awaitables: Awaitable[_T]) -> list[_T]:
    # One awaitable (the common plan: one series per job) needs no task to gather.
    if len(awaitables) == 1:
        return [await awaitables[0]]
    if not awaitables:
        return []
    return list(await asyncio.gather(*awaitables))


def decode_values(payload: bytes, *, source: str) -> pl.Series:
    """The values of a serialized plain (not per-category) MetricsData, as a series.

    Per-category data has no single series (its categories have names): InvalidDataError
    says so; read it with `stook.sdk.read_metrics_data` instead.
    """
    try:
        view = read_metrics_data(payload, source=source)
        if view.per_category:
            raise InvalidDataError(
                f"{source}: metrics data {view.name!r} is per category; it has no single series"
            )
        return view.series()
    except ReadError as exc:
        if isinstance(exc, InvalidDataError):
            raise
        raise InvalidDataError(str(exc)) from None
