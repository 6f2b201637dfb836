"""Batch mode with `[batch.baseline]`: the baseline's jobs fetched beside the batch's own.

One fetcher for the pipeline (`ComparedFetcher`): the candidate's `BatchFetcher` folds
into every aggregation as usual, while, on the same client (so under the same bound on
requests in flight), the baseline is found and its jobs fetched by a second
`BatchFetcher` whose records feed the comparison's baseline side. Once both are in, the
metrics without a configured direction get one from their failure definitions.

The `[batch.baseline]` table it runs on (`BaselineSettings`, `parse_baseline`) is at the
end of this module.
"""

from __future__ import annotations

import asyncio
import uuid
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import structlog

from stook.service.api import ApiClient
from stook.service.fetch import (
    BatchFetcher,
    FetchOutcome,
    OnEmissions,
    failure_directions,
    find_baseline,
)
from stook.service.modes._errors import check_number

if TYPE_CHECKING:
    # The comparison's module (and its statistics) is imported by the run that has one.
    from stook.sdk.aggregations import JobRecord, Needs
    from stook.sdk.aggregations.baseline import BaselineComparison
    from stook.sdk.stats import Better

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
        workers: int | None = None,
        on_progress: Callable[[FetchOutcome], None] | None = None,
        on_emissions: OnEmissions | None = None,
    ) -> None:
        """`workers`: each fetch's (default: the client's concurrency)."""
        self._api = api
        self._workers = workers
        self._project_id = project_id
        self._batch_id = batch_id
        self._comparison = comparison
        self._settings = settings
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
    workers: int | None = None,
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


# --- the [batch.baseline] table --------------------------------------------------------------

# `[batch.baseline]`: which batch to compare with, and how; checked before any request.
#
# [batch.baseline]
# previous = true            # or: branch = "main" (a name or an ID), or: batch = "<uuid>"
# metrics = ["Localization error"]   # default: every SCALAR job metric both batches have
# better = { "Max speed" = "higher" }  # default: from each metric's failure definition
# min_effect = 0.05          # relative; smaller significant changes are NO CHANGE
# confidence = 0.95
# correction = "holm"        # or "none"
# resamples = 2000
# block_on_regression = false

_KEYS = {
    "batch",
    "branch",
    "previous",
    "metrics",
    "better",
    "min_effect",
    "confidence",
    "correction",
    "resamples",
    "block_on_regression",
}
_CORRECTIONS = ("holm", "none")


class BaselineConfigError(ValueError):
    """A bad [batch.baseline] table; the config loader turns it into a ConfigError."""


@dataclass(frozen=True, slots=True)
class BaselineSettings:
    """Which baseline (exactly one of the three) and the comparison's options."""

    batch: uuid.UUID | None = None
    branch: str | None = None
    previous: bool = False
    metrics: tuple[str, ...] | None = None
    better: Mapping[str, Better] = field(default_factory=dict)
    min_effect: float = 0.05
    confidence: float = 0.95
    correction: str = "holm"
    resamples: int = 2000
    block_on_regression: bool = False

    def comparison(self) -> BaselineComparison:
        """A fresh comparison aggregation with these options."""
        # Imported by the run that has a [batch.baseline], with its statistics: not by every run.
        from stook.sdk.aggregations.baseline import BaselineComparison

        return BaselineComparison(
            metrics=self.metrics,
            better=dict(self.better),
            min_effect=self.min_effect,
            confidence=self.confidence,
            correction=self.correction,
            resamples=self.resamples,
            block_on_regression=self.block_on_regression,
        )


def parse_baseline(table: Any) -> BaselineSettings:
    """The settings of a [batch.baseline] table; BaselineConfigError names what is wrong."""
    where = "[batch.baseline]"
    if not isinstance(table, dict):
        raise BaselineConfigError(f"{where} must be a table (one [batch.baseline], not a list)")
    unknown = sorted(set(table) - _KEYS)
    if unknown:
        raise BaselineConfigError(
            f"unknown key {unknown[0]!r} in {where} (known: {', '.join(sorted(_KEYS))})"
        )
    chosen = [k for k in ("batch", "branch", "previous") if k in table]
    if len(chosen) != 1:
        raise BaselineConfigError(
            f"{where} needs exactly one of batch, branch or previous"
            + (f" (got {', '.join(chosen)})" if chosen else "")
        )
    batch: uuid.UUID | None = None
    if "batch" in table:
        try:
            batch = uuid.UUID(str(table["batch"]))
        except ValueError:
            raise BaselineConfigError(
                f"{where} batch must be a batch ID (a UUID), got {table['batch']!r}"
            ) from None
    branch = table.get("branch")
    if branch is not None and (not isinstance(branch, str) or not branch.strip()):
        raise BaselineConfigError(f"{where} branch must be a branch name or ID")
    if "previous" in table and table["previous"] is not True:
        raise BaselineConfigError(f"{where} previous must be true (or left out)")
    metrics = table.get("metrics")
    if metrics is not None and (
        not isinstance(metrics, list)
        or not metrics
        or not all(isinstance(m, str) and m for m in metrics)
    ):
        raise BaselineConfigError(f"{where} metrics must be a non-empty list of metric names")
    better = table.get("better", {})
    if not isinstance(better, dict):
        raise BaselineConfigError(f'{where} better must be a table: {{ "Metric" = "lower" }}')
    for name, value in better.items():
        if value not in ("lower", "higher"):
            raise BaselineConfigError(
                f'{where} better for {name!r} must be "lower" or "higher", got {value!r}'
            )
        if metrics is not None and name not in metrics:
            raise BaselineConfigError(
                f"{where} better names {name!r}, which is not one of its metrics"
            )

    def number(key: str, default: float, low: float, high: float, *, whole: bool = False) -> Any:
        value = table.get(key, default)
        return check_number(
            value, f"{where} {key}", whole=whole, between=(low, high), error=BaselineConfigError
        )

    confidence = number("confidence", 0.95, 0.5, 0.999)
    min_effect = number("min_effect", 0.05, 0.0, 10.0)
    resamples = number("resamples", 2000, 100, 100_000, whole=True)
    correction = table.get("correction", "holm")
    if correction not in _CORRECTIONS:
        raise BaselineConfigError(
            f"{where} correction must be one of {', '.join(_CORRECTIONS)}, got {correction!r}"
        )
    block = table.get("block_on_regression", False)
    if not isinstance(block, bool):
        raise BaselineConfigError(f"{where} block_on_regression must be true or false")
    return BaselineSettings(
        batch=batch,
        branch=branch.strip() if isinstance(branch, str) else None,
        previous=bool(table.get("previous", False)),
        metrics=tuple(metrics) if metrics is not None else None,
        better=dict(better),
        min_effect=min_effect,
        confidence=confidence,
        correction=correction,
        resamples=resamples,
        block_on_regression=block,
    )
