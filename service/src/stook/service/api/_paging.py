"""Telling a listing that will not end from a long one, from what its pages prove."""

from __future__ import annotations

from collections.abc import Callable
from typing import Final, NoReturn, TypeVar

from stook.service.api._errors import ApiResponseError

__all__ = ["ListingGuard"]

_Item = TypeVar("_Item")
# Empty pages that each hand out a new token: a server may skip ahead over a few, never
# over this many (156,000 a minute were seen from a server that never stopped).
_MAX_EMPTY_PAGES: Final = 50


class ListingGuard:
    """Stops a listing whose pages prove it will not end, instead of following it for ever.

    Only what the answers themselves prove counts: a page token seen before; a page of
    nothing but items listed already (the same jobs again and again); an empty page with a
    further token once the listing's own ``total`` has been delivered, or more items than
    that total by a whole page; and a long run of empty pages that each carry a new token.
    The first ``total`` a page carries bounds every later page, those without one too: a
    listing that drops it after a few pages cannot go on for ever with fresh items. Until
    a page carries one, ``expected`` (what the caller knows of the count: a batch's
    ``totalJobs``) bounds it the same way.
    """

    def __init__(
        self,
        listing: str | Callable[[], str],
        item_id: str,
        page_size: int,
        *,
        expected: int | None = None,
    ) -> None:
        # `listing` names the listing in the error; a function makes that name only then.
        self._listing = listing
        self._item_id = item_id  # the items' attribute that identifies each
        self._page_size = page_size
        self._tokens: set[str] = set()
        self._seen: set[object] = set()
        self._pages = 0
        self._empty_run = 0
        self._total: int | None = None  # the first total a page carried
        self._expected = expected

    def check(self, items: list[_Item], token: str | None, total: int | None) -> list[_Item]:
        """The page's items to hand on: those not listed before, by their ID.

        Paging by offset while a listing changes can repeat an item on a later page; a
        caller wants each job (metric, batch) once, so a repeat is dropped here, for every
        listing, and a page that holds nothing else ends the listing as endless.
        """
        self._pages += 1
        if token is None and self._pages == 1:
            # A listing of one page, as most are (a job's): nothing to compare it with.
            return items
        fresh: list[_Item] = []
        for item in items:
            identity = getattr(item, self._item_id)
            if identity not in self._seen:
                self._seen.add(identity)
                fresh.append(item)
        if token is None:
            return fresh  # the last page: nothing more will be asked for
        if token in self._tokens:
            self._stop("the API repeated a page token")
        self._tokens.add(token)
        if items and not fresh:
            self._stop(f"page {self._pages} holds only items listed on earlier pages")
        self._empty_run = 0 if items else self._empty_run + 1
        if self._total is None:
            self._total = total
        total = self._total if self._total is not None else self._expected
        if total is not None:
            if not items and len(self._seen) >= total:
                self._stop(
                    f"page {self._pages} is empty and all {total} items of the listing's "
                    "total have been listed, yet it hands out another page token"
                )
            if len(self._seen) > total + self._page_size:
                self._stop(
                    f"{len(self._seen)} items listed, more than the listing's total of {total}"
                )
        if self._empty_run >= _MAX_EMPTY_PAGES:
            self._stop(f"{self._empty_run} empty pages in a row, each with a new page token")
        return fresh

    def _stop(self, why: str) -> NoReturn:
        listing = self._listing if isinstance(self._listing, str) else self._listing()
        raise ApiResponseError(f"{listing}: the listing does not end ({why})")
