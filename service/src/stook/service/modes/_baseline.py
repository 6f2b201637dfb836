"""Batch mode with `[batch.baseline]`: the baseline's jobs fetched beside the batch's own.

One fetcher for the pipeline (`ComparedFetcher`): the candidate's `BatchFetcher` folds
into every aggregation as usual, while, on the same client (so under the same bound on
requests in flight), the baseline is found and its jobs fetched by a second
`BatchFetcher` whose records feed the comparison's baseline side. Once both are in, the
metrics without a configured direction get one from their failure definitions.
"""

from __future__ import annotations

import asyncio
import uuid
from collections.abc import Callable
from typing import TYPE_CHECKING

import structlog

from stook.service.api import ApiClient
from stook.service.fetch import (
    BatchFetcher,
    FetchOutcome,
    OnEmissions,
    failure_directions,
    find_baseline,
)
from stook.service.modes._baseline_config import BaselineSettings

if TYPE_CHECKING:
    # The comparison's module (and its statistics) is imported by the run that has one.
    from stook.sdk.aggregations import JobRecord, Needs
    from stook.sdk.aggregations.baseline import BaselineComparison

log = structlog.get_logger("stook.baseline")


class ComparedFetcher:
    """The batch's fetch and its baseline's, run together; `outcome` is the batch's."""

    def __init__(
        self,
        api: ApiClient,
        project_id: uuid.UUID,
        batch_id: uuid.UUID,
        needs: Needs,
        comparison: BaselineComparison,
        settings: BaselineSettings,
        *,
        workers: int,
        on_progress: Callable[[FetchOutcome], None] | None = None,
        on_emissions: OnEmissions | None = None,
    ) -> None:
        self._api = api
        self._project_id = project_id
        self._batch_id = batch_id
        self._comparison = comparison
        self._settings = settings
        self._workers = workers
        self._candidate = BatchFetcher(
            api,
            project_id,
            batch_id,
            needs,
            workers=workers,
            on_progress=on_progress,
            on_emissions=on_emissions,
        )

    @property
    def outcome(self) -> FetchOutcome:
        return self._candidate.outcome

    async def run(self, on_job: Callable[[JobRecord], None]) -> FetchOutcome:
        try:
            async with asyncio.TaskGroup() as group:
                candidate = group.create_task(self._candidate.run(on_job))
                group.create_task(self._fetch_baseline())
        except ExceptionGroup as group_error:
            raise group_error.exceptions[0] from None
        await set_directions(self._api, self._project_id, self._batch_id, self._comparison)
        return candidate.result()

    async def _fetch_baseline(self) -> None:
        await fetch_baseline(
            self._api,
            self._project_id,
            self._batch_id,
            self._comparison,
            self._settings,
            workers=self._workers,
        )


async def fetch_baseline(
    api: ApiClient,
    project_id: uuid.UUID,
    batch_id: uuid.UUID,
    comparison: BaselineComparison,
    settings: BaselineSettings,
    *,
    workers: int,
) -> None:
    """Find the baseline of `batch_id` and fold its jobs into the comparison's baseline side
    (or say there is none). A sharded run does this on its driver, beside the shards."""
    found = await find_baseline(
        api,
        project_id,
        batch_id,
        batch=settings.batch,
        branch=settings.branch,
        previous=settings.previous,
    )
    baseline = found.baseline
    if baseline is None:
        log.info("no baseline to compare with", reason=found.reason)
        comparison.no_baseline(found.reason)
        return
    log.info("baseline found", baseline_id=str(baseline.batch_id), chosen_as=found.chosen_as)
    fetcher = BatchFetcher(api, project_id, baseline.batch_id, comparison.needs(), workers=workers)
    outcome = await fetcher.run(comparison.update_baseline)
    from stook.sdk.aggregations.baseline import BaselineInfo  # imported by comparison()

    comparison.set_baseline(
        BaselineInfo(
            batch_id=baseline.batch_id,
            friendly_name=baseline.friendly_name or "",
            build=found.build,
            created=baseline.creation_timestamp,
            chosen_as=found.chosen_as,
            missing_jobs=len(outcome.missing),
        ),
        batch_id,
    )


async def set_directions(
    api: ApiClient, project_id: uuid.UUID, batch_id: uuid.UUID, comparison: BaselineComparison
) -> None:
    """Once both sides are in: which way is better for the compared metrics that have no
    configured direction, from their failure definitions."""
    probes = comparison.direction_probes()
    if probes and comparison.found is not None:
        comparison.set_directions(await failure_directions(api, project_id, batch_id, probes))
