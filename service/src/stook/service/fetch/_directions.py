"""Which way each SCALAR job metric is better, read from its failure definition.

A metric that fails above a limit is better lower, one that fails below a limit better
higher; with both (a band) or neither there is no direction. The definition is in the
metric's message, not its listing: one job's listing and one download per metric name,
whatever the batch's size. A probe that fails leaves that metric without a direction
(compared two-sided), said in a warning.
"""

from __future__ import annotations

import uuid
from collections import defaultdict
from collections.abc import Mapping
from typing import TYPE_CHECKING

import structlog

from stook.sdk import ReadError, read_metric
from stook.service.api import ApiClient, ApiError, ApiMetric, AuthError, OriginUnavailableError
from stook.service.fetch._presigned import fetch_listed
from stook.service.fetch._scalars import is_scalar

if TYPE_CHECKING:
    from stook.sdk.stats import Better  # an alias: not worth the statistics' imports

__all__ = ["failure_directions"]

log = structlog.get_logger("stook.baseline")


def direction_of(fails_above: bool, fails_below: bool) -> Better | None:
    if fails_above and not fails_below:
        return "lower"
    if fails_below and not fails_above:
        return "higher"
    return None


async def failure_directions(
    api: ApiClient,
    project_id: uuid.UUID,
    batch_id: uuid.UUID,
    probes: Mapping[str, uuid.UUID],
) -> dict[str, Better | None]:
    """Per metric name, its direction, read from the job named for it in `probes`."""
    by_job: dict[uuid.UUID, list[str]] = defaultdict(list)
    for name, job_id in probes.items():
        by_job[job_id].append(name)
    out: dict[str, Better | None] = dict.fromkeys(probes)
    for job_id, names in sorted(by_job.items()):

        async def listing(job: uuid.UUID = job_id) -> list[ApiMetric]:
            return await api.list_job_metrics(project_id, batch_id, job)

        try:
            metrics = await listing()
            for metric in metrics:
                if not is_scalar(metric) or metric.name not in names or out[metric.name]:
                    continue
                source = f"job {job_id} / metric {metric.name!r}"
                payload, _ = await fetch_listed(
                    api.storage,
                    metric,
                    url_of=lambda m: m.metric_url,
                    id_of=lambda m: m.metric_id,
                    relist=listing,
                    source=source,
                )
                if payload is None:
                    continue
                view = read_metric(payload, source=source)
                definition = view.raw.metric_values.scalar_metric_values.failure_definition
                out[metric.name] = direction_of(
                    definition.HasField("fails_above"), definition.HasField("fails_below")
                )
        except (AuthError, OriginUnavailableError):
            raise
        except (ApiError, ReadError) as exc:
            log.warning(
                "failure definition unavailable; compared two-sided",
                job_id=str(job_id),
                metrics=sorted(names),
                reason=str(exc),
            )
    return out
