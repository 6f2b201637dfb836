"""A job's events and its experience's tags, for plans that ask for them.

Events cost one listing per job (`Needs.events`). Tags belong to the experience, not the
job: they are listed once per experience (`Needs.experience_tags`), and every job of that
experience, running at the same time or later, shares that one request.
"""

from __future__ import annotations

import asyncio
import uuid

from stook.sdk.aggregations import JobEvent
from stook.service.api import ApiClient, JobEventListing

__all__ = ["ExperienceTags", "job_event"]


def job_event(listed: JobEventListing) -> JobEvent:
    """An event as aggregations read it: statuses and timestamp types as the API spells them."""
    return JobEvent(
        event_id=listed.event_id,
        name=listed.name,
        status=str(listed.status),
        timestamp=listed.timestamp,
        timestamp_type=str(listed.timestamp_type or ""),
        description=listed.description,
        tags=listed.tags,
        metric_ids=listed.metric_ids,
    )


class ExperienceTags:
    """The sorted tag names of each experience, listed once per experience.

    Each experience's listing is a task of its own, shielded from the jobs waiting for it:
    one job being cancelled must not cancel the listing the others wait on. A listing that
    failed fails every job of that experience alike (no request storm). `aclose` cancels
    listings nobody waits for any more.
    """

    def __init__(self, api: ApiClient, project_id: uuid.UUID) -> None:
        self._api = api
        self._project_id = project_id
        self._listings: dict[uuid.UUID, asyncio.Task[tuple[str, ...]]] = {}

    async def of(self, experience_id: uuid.UUID | None) -> tuple[str, ...]:
        if experience_id is None:
            return ()
        listing = self._listings.get(experience_id)
        if listing is None:
            listing = asyncio.create_task(self._list(experience_id))
            self._listings[experience_id] = listing
        return await asyncio.shield(listing)

    async def _list(self, experience_id: uuid.UUID) -> tuple[str, ...]:
        names = [
            tag.name
            async for tag in self._api.list_experience_tags(self._project_id, experience_id)
            if tag.name
        ]
        return tuple(sorted(names))

    async def aclose(self) -> None:
        pending = [task for task in self._listings.values() if not task.done()]
        for task in pending:
            task.cancel()
        if pending:
            await asyncio.gather(*pending, return_exceptions=True)
        # A failed listing whose jobs all went away would be logged as never retrieved.
        for task in self._listings.values():
            if task.done() and not task.cancelled():
                task.exception()
