"""A batch's stook summary, when its batch metrics build wrote one: one listing, one download.

Batch mode writes the summary (`BatchSummaryWriter`) as batch metrics data named
`SUMMARY_DATA_NAME`. Report mode reads it instead of listing the batch's jobs and every
job's metrics. Anything short of a summary this code can read in full (none listed, no
URL, a newer layout, bytes that are not a summary) returns None with the reason logged,
and the report lists that batch's jobs as before: a wrong number is never an option.
"""

from __future__ import annotations

import uuid

import structlog

from stook.sdk import ReadError, read_metrics_data
from stook.sdk.aggregations import (
    SUMMARY_DATA_NAME,
    ColumnarSummary,
    SummaryError,
    SummaryVersionError,
    summary_columns_from_data,
)
from stook.service.api import ApiClient, ApiMetricsData
from stook.service.fetch._presigned import fetch_listed

__all__ = ["read_summary"]

log = structlog.get_logger("stook.report")


async def read_summary(
    api: ApiClient, project_id: uuid.UUID, batch_id: uuid.UUID
) -> ColumnarSummary | None:
    """The batch's summary, as columns, or None when it has none that this code can read."""
    listed = await _list(api, project_id, batch_id)
    found = [d for d in listed if d.name == SUMMARY_DATA_NAME and d.is_standard]
    if not found:
        log.debug("batch has no stook summary; listing its jobs", batch_id=str(batch_id))
        return None
    source = f"batch {batch_id} / {SUMMARY_DATA_NAME}"
    payload, _ = await fetch_listed(
        api.storage,
        found[0],
        url_of=lambda d: d.metrics_data_url,
        id_of=lambda d: d.data_id,
        relist=lambda: _list(api, project_id, batch_id),
        source=source,
    )
    if payload is None:
        log.warning("batch summary has no URL; listing the batch's jobs", batch_id=str(batch_id))
        return None
    try:
        return summary_columns_from_data(read_metrics_data(payload, source=source))
    except SummaryVersionError as exc:
        log.warning(
            "batch summary written by a newer stook; listing the batch's jobs",
            batch_id=str(batch_id),
            reason=str(exc),
        )
    except (SummaryError, ReadError) as exc:
        log.warning(
            "batch summary unreadable; listing the batch's jobs",
            batch_id=str(batch_id),
            reason=str(exc),
        )
    return None


async def _list(api: ApiClient, project_id: uuid.UUID, batch_id: uuid.UUID) -> list[ApiMetricsData]:
    return [d async for d in api.list_batch_metrics_data(project_id, batch_id)]
