"""What `stook bench --probe` sends: the GETs a run of these inputs and this config sends.

The plan is read as `stook run` reads it (the inputs folder's platform config, stook.toml's
aggregations and their `Needs`); `prepare` lists what the requests are about (the batch's
jobs, or the report's batches) once, before any level; `visit` then sends, for one job or
one batch, the requests a run sends for it: listings on the API, and downloads of the
blobs the aggregations read from storage. Nothing is written to the API.
"""

from __future__ import annotations

import itertools
import uuid
from collections.abc import AsyncIterator, Awaitable, Callable, Iterator
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any, Literal, Protocol, TypeVar

from stook.sdk.aggregations import SUMMARY_DATA_NAME, Needs
from stook.service.api import ApiClient, ApiResponseError, Batch, Job
from stook.service.fetch import ReportFetcher
from stook.service.modes import (
    ApiAccess,
    BatchInputs,
    InputsError,
    StookConfig,
    TestInputs,
    batch_aggregations,
    detect,
    load,
    report_aggregations,
)

__all__ = ["Origin", "ProbePlan", "Timer", "read_plan"]

Origin = Literal["api", "storage"]
_T = TypeVar("_T")

# Jobs (or batches) listed before the levels, cycled through by the visits: enough that a
# level's requests are spread over many jobs, few enough that listing them is quick.
MAX_UNITS = 1_000


class Timer(Protocol):
    """Sends one request under a level's budget, timed as `origin`'s; None if it failed."""

    def __call__(
        self, origin: Origin, call: Callable[[], Awaitable[_T]]
    ) -> Awaitable[_T | None]: ...


@dataclass(slots=True)
class ProbePlan:
    """The inputs' batch or report, what the config's aggregations read, and the units
    (jobs or batches) the visits cycle through once `prepare` has listed them."""

    kind: Literal["batch", "report"]
    access: ApiAccess
    target_id: uuid.UUID  # the batch's or the report's ID
    needs: Needs
    config: StookConfig
    use_summaries: bool = True
    units: list[Job] | list[Batch] = field(default_factory=list)

    async def prepare(self, api: ApiClient) -> None:
        """List the batch's jobs (or the report's batches): the probe's first requests,
        which also prove the API reachable and the token good."""
        project = self.access.project_id
        if self.kind == "batch":
            self.units = await _first(api.list_jobs(project, self.target_id), MAX_UNITS)
            what = f"batch {self.target_id} lists no jobs"
        else:
            fetcher = ReportFetcher(api, project, self.target_id, self.needs)
            _, batches = await fetcher.find_batches()
            self.units = batches[:MAX_UNITS]
            what = f"report {self.target_id} has no batches"
        if not self.units:
            raise ApiResponseError(f"{what}: nothing to probe")

    def visits(self) -> Iterator[Callable[[ApiClient, Timer], Awaitable[None]]]:
        """The visits of one level, endlessly: each unit in turn, over and over."""
        visit = self._visit_job if self.kind == "batch" else self._visit_batch
        for index, unit in enumerate(itertools.cycle(self.units)):
            yield partial(visit, unit, index)

    async def _visit_job(self, job: Any, index: int, api: ApiClient, timed: Timer) -> None:
        """A job as batch mode fetches it (see stook.service.fetch's BatchFetcher)."""
        needs, project, batch = self.needs, self.access.project_id, self.target_id
        page_size = self.config.fetch.page_size
        if index % page_size == 0:  # a run lists a page of jobs for every `page_size` jobs
            jobs_page = partial(_page, api, f"{self._batch_path(batch)}/jobs", "jobs", page_size)
            await timed("api", jobs_page)
        wants_metrics = bool(needs.metrics) or needs.every_metric
        listed_metrics = await timed(
            "api", partial(api.list_job_metrics, project, batch, job.job_id)
        )
        metrics = listed_metrics if wants_metrics else []
        if needs.data or wants_metrics:
            listed = await timed(
                "api", partial(api.list_job_metrics_data, project, batch, job.job_id)
            )
            wanted = needs.data | needs.data_with_index
            for data in listed or ():
                url = data.metrics_data_url
                if url and (needs.every_metric or data.name in wanted):
                    await timed("storage", partial(api.storage.fetch_bytes, url))
        for metric in metrics or ():
            url = metric.metric_url
            if url and (needs.every_metric or metric.name in needs.metrics):
                await timed("storage", partial(api.storage.fetch_bytes, url))
        if needs.events:
            path = f"{self._batch_path(batch)}/jobs/{job.job_id}/events"
            await timed("api", partial(_page, api, path, "events", page_size))

    async def _visit_batch(self, batch: Any, index: int, api: ApiClient, timed: Timer) -> None:
        """A batch as report mode fetches it (see stook.service.fetch's ReportFetcher)."""
        project, batch_id = self.access.project_id, batch.batch_id
        page_size = self.config.fetch.page_size
        path = self._batch_path(batch_id)
        await timed("api", partial(_page, api, f"{path}/metrics", "batchMetrics", page_size))
        if self.use_summaries:
            listing = partial(_page, api, f"{path}/metricsData", "batchMetricsData", page_size)
            listed = await timed("api", listing)
            for data in listed or ():
                url = data.get("metricsDataURL")
                if isinstance(url, str) and url and data.get("name") == SUMMARY_DATA_NAME:
                    await timed("storage", partial(api.storage.fetch_bytes, url))
                    return  # the summary stands for the batch's job listings
        jobs = await timed("api", partial(_page, api, f"{path}/jobs", "jobs", page_size))
        if self.needs.job_metrics:
            for job in jobs or ():
                job_id = job.get("jobID")
                if isinstance(job_id, str):
                    metrics = partial(api.list_job_metrics, project, batch_id, job_id)
                    await timed("api", metrics)

    def _batch_path(self, batch_id: uuid.UUID) -> str:
        return f"/projects/{self.access.project_id}/batches/{batch_id}"


def read_plan(inputs: Path, config: Path | None, project_id: uuid.UUID | None) -> ProbePlan:
    """The plan of a run of `inputs` with stook.toml `config`; raises what `stook run`
    raises for bad inputs or config (InputsError, ConfigError: exit code 2)."""
    settings = load(config)
    found = detect(inputs, project_id=project_id)
    if isinstance(found, TestInputs):
        raise InputsError(
            f"inputs folder {str(inputs)!r} is a test-mode folder: a probe needs a batch or "
            "report config (batch_metrics_config.json or report_config.json)"
        )
    if isinstance(found, BatchInputs):
        aggregations: list[Any] = list(batch_aggregations(settings).all)
        return ProbePlan("batch", found.access, found.batch_id, _needs(aggregations), settings)
    return ProbePlan(
        "report",
        found.access,
        found.report_id,
        _needs(report_aggregations(settings, str(found.access.project_id))),
        settings,
        use_summaries=settings.report.use_summaries,
    )


def _needs(aggregations: list[Any]) -> Needs:
    needs = Needs()
    for aggregation in aggregations:
        needs = needs | aggregation.needs()
    return needs


async def _page(api: ApiClient, path: str, key: str, page_size: int) -> list[dict[str, Any]]:
    """The first page of the listing at `path`: one request, as a run sends for each page
    of it. Its items under `key`, as the API wrote them."""
    document = await api.get_json(path, {"pageSize": page_size})
    items = document.get(key)
    return [item for item in items if isinstance(item, dict)] if isinstance(items, list) else []


async def _first(items: AsyncIterator[_T], count: int) -> list[_T]:
    """Up to `count` items of a listing, page after page."""
    taken: list[_T] = []
    async for item in items:
        taken.append(item)
        if len(taken) >= count:
            break
    return taken
