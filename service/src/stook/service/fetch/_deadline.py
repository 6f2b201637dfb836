"""`[fetch] deadline`: a bound on the whole fetch, for platforms that kill a job after a while.

Without it a run facing a slow or failing API takes as long as the retry budgets allow;
with it, the fetch stops at the deadline and the run exits 3 with one line saying how far
it got, before the platform's own timeout kills it without a word.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import AsyncIterator, Callable

from stook.service.fetch._errors import DeadlineReachedError

__all__ = ["fetch_deadline"]


@contextlib.asynccontextmanager
async def fetch_deadline(
    seconds: float | None, *, started: float, progress: Callable[[], str]
) -> AsyncIterator[None]:
    """Cancel the body `seconds` after `started` (the event loop's clock); None: no limit.

    On expiry raises :class:`DeadlineReachedError` saying ``progress()``, e.g.
    "1,204 of 5,000 jobs".
    """
    if seconds is None:
        yield
        return
    timeout = asyncio.timeout_at(started + seconds)
    try:
        async with timeout:
            yield
    except TimeoutError:
        if not timeout.expired():
            raise  # a timeout of something inside, not ours
        raise DeadlineReachedError(
            f"deadline of {seconds:g} s ([fetch] deadline) reached after {progress()}"
        ) from None
