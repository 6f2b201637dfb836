"""Finding the batch to compare a batch with: named, the latest on a branch, or the previous.

A baseline is a finished (SUCCEEDED) batch of the same test suite, created before the
batch compared, found with the platform's batch `search` filter (test suite, branch,
creation time, status; see the API spec's listBatches) and checked again here, since a
filter the platform ignores must not pick a wrong batch. A branch given by name is looked
up with the branches listing's `name` filter. When there is no such batch the answer says
why (`BaselineFound.reason`): no baseline is not an error.

Which way is better for a compared metric, from its failure definitions
(`failure_directions`), is at the end of this module.
"""

from __future__ import annotations

import uuid
from collections import defaultdict
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import structlog

from stook.sdk import ReadError, read_metric
from stook.service.api import (
    ApiClient,
    ApiError,
    ApiMetric,
    AuthError,
    Batch,
    BatchStatus,
    NotFoundError,
    OriginUnavailableError,
)
from stook.service.fetch._presigned import fetch_listed
from stook.service.fetch._scalars import is_scalar

if TYPE_CHECKING:
    from stook.sdk.stats import Better  # an alias: not worth the statistics' imports

__all__ = ["BaselineFound", "failure_directions", "find_baseline"]

log = structlog.get_logger("stook.baseline")


@dataclass(frozen=True, slots=True)
class BaselineFound:
    """The batch compared (`candidate`), its baseline (None: `reason` says why) and how it
    was chosen; `build` labels the baseline's build ("" when unknown)."""

    candidate: Batch
    baseline: Batch | None
    chosen_as: str = ""
    reason: str = ""
    build: str = ""


async def find_baseline(
    api: ApiClient,
    project_id: uuid.UUID,
    candidate_id: uuid.UUID,
    *,
    batch: uuid.UUID | None = None,
    branch: str | None = None,
    previous: bool = False,
) -> BaselineFound:
    """The baseline chosen by exactly one of `batch`, `branch` or `previous`."""
    candidate = await api.get_batch(project_id, candidate_id)
    if batch is not None:
        return await _named(api, project_id, candidate, batch)
    if branch is not None:
        branch_id = await _branch_id(api, project_id, branch)
        if branch_id is None:
            return BaselineFound(candidate, None, reason=f"project has no branch named {branch!r}")
        found = await _latest_before(api, project_id, candidate, branch_id)
        where = f"on branch {branch}"
    elif previous:
        if candidate.branch_id is None:
            return BaselineFound(candidate, None, reason="this batch names no branch")
        found = await _latest_before(api, project_id, candidate, candidate.branch_id)
        where = "on this batch's branch"
    else:
        raise ValueError("one of batch, branch or previous is needed")
    if isinstance(found, str):
        return BaselineFound(candidate, None, reason=found)
    chosen = f"the latest finished batch of this test suite {where} before this one"
    return BaselineFound(candidate, found, chosen, build=await _build_label(api, project_id, found))


async def _named(
    api: ApiClient, project_id: uuid.UUID, candidate: Batch, batch_id: uuid.UUID
) -> BaselineFound:
    if batch_id == candidate.batch_id:
        return BaselineFound(candidate, None, reason="[batch.baseline] batch is this batch")
    try:
        baseline = await api.get_batch(project_id, batch_id)
    except NotFoundError:
        return BaselineFound(
            candidate, None, reason=f"batch {batch_id} does not exist in project {project_id}"
        )
    chosen = "as named in [batch.baseline]"
    if baseline.test_suite_id != candidate.test_suite_id:
        chosen += " (a different test suite: only experiences both ran are paired)"
    return BaselineFound(
        candidate, baseline, chosen, build=await _build_label(api, project_id, baseline)
    )


async def _branch_id(api: ApiClient, project_id: uuid.UUID, branch: str) -> uuid.UUID | None:
    try:
        return uuid.UUID(branch)
    except ValueError:
        pass
    async for found in api.list_branches(project_id, name=branch):
        if found.name == branch:  # the filter may match more loosely than equality
            return found.branch_id
    return None


async def _latest_before(
    api: ApiClient, project_id: uuid.UUID, candidate: Batch, branch_id: uuid.UUID
) -> Batch | str:
    suite = candidate.test_suite_id
    if suite is None:
        return "this batch has no test suite (an ad-hoc batch): name a baseline batch instead"
    clauses = [f'test_suite_id = "{suite}"', f'branch_id = "{branch_id}"']
    created = candidate.creation_timestamp
    if created is not None:
        clauses.append(f'created_at < "{created.isoformat()}"')
    clauses.append(f'status = "{BatchStatus.SUCCEEDED}"')
    best: Batch | None = None
    async for batch in api.list_batches(project_id, search=" AND ".join(clauses)):
        if (
            batch.batch_id == candidate.batch_id
            or batch.test_suite_id != suite
            or batch.branch_id != branch_id
            or batch.status != BatchStatus.SUCCEEDED
            or batch.creation_timestamp is None
            or (created is not None and batch.creation_timestamp >= created)
        ):
            continue
        key = (batch.creation_timestamp, batch.batch_id)
        if best is None or key > (best.creation_timestamp, best.batch_id):
            best = batch
    if best is None:
        return f"no finished batch of test suite {suite} on branch {branch_id} before this one"
    return best


async def _build_label(api: ApiClient, project_id: uuid.UUID, batch: Batch) -> str:
    """The build's name and version, for the text; a label is not worth failing the run."""
    if batch.build_id is None:
        return ""
    try:
        build = await api.get_build(project_id, batch.build_id)
    except ApiError as exc:
        log.warning("baseline build unavailable", build_id=str(batch.build_id), reason=str(exc))
        return str(batch.build_id)
    parts = [p for p in (build.name, build.version) if p]
    if len(parts) == 2 and parts[1] in parts[0]:
        parts = parts[:1]
    return " ".join(parts[:1]) + (f" ({parts[1]})" if len(parts) > 1 else "") or str(build.build_id)


# --- which way is better: failure directions -------------------------------------------------

# Which way each SCALAR job metric is better, read from its failure definition.
#
# A metric that fails above a limit is better lower, one that fails below a limit better
# higher; with both (a band) or neither there is no direction. The definition is in the
# metric's message, not its listing: one job's listing and one download per metric name,
# whatever the batch's size. A probe that fails leaves that metric without a direction
# (compared two-sided), said in a warning.


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
