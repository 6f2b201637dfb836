"""The batch `search` filter: ` AND `-joined clauses, the forms a report's fetch uses."""

from __future__ import annotations

import re
import uuid
from collections.abc import Callable
from datetime import UTC, datetime

from stook.emulator._world import BatchSpec

BatchFilter = Callable[[BatchSpec], bool]

_ID_CLAUSE = re.compile(r'(test_suite_id|branch_id) = "([^"]*)"')
_TIME_CLAUSE = re.compile(r'created_at ([<>]) "([^"]*)"')
_REVISION_CLAUSE = re.compile(r"test_suite_revision = (\d+)")
_STATUS_CLAUSE = re.compile(r'status = "([A-Z_]+)"')


class SearchError(ValueError):
    """A search string the API would answer with 400."""


def parse_search(text: str) -> list[BatchFilter]:
    """The filters of a search string; all must hold. An empty string filters nothing."""
    if not text.strip():
        return []
    return [_clause(part.strip()) for part in text.split(" AND ")]


def _clause(part: str) -> BatchFilter:
    if m := _ID_CLAUSE.fullmatch(part):
        field, value = m.group(1), _uuid(m.group(2))
        if field == "test_suite_id":
            return lambda b: b.test_suite_id == value
        return lambda b: b.branch_id == value
    if m := _TIME_CLAUSE.fullmatch(part):
        op, moment = m.group(1), _timestamp(m.group(2))
        if op == ">":
            return lambda b: b.created > moment
        return lambda b: b.created < moment
    if m := _REVISION_CLAUSE.fullmatch(part):
        revision = int(m.group(1))
        return lambda b: b.test_suite_revision == revision
    if m := _STATUS_CLAUSE.fullmatch(part):
        status = m.group(1)
        return lambda b: b.status == status
    raise SearchError(f"unsupported search clause {part!r}")


def _uuid(text: str) -> uuid.UUID:
    try:
        return uuid.UUID(text)
    except ValueError:
        raise SearchError(f"{text!r} is not a UUID") from None


def _timestamp(text: str) -> datetime:
    # Both RFC 3339 ("...T...Z") and Python's str(datetime) ("... +00:00") are sent by
    # real clients; fromisoformat reads both.
    try:
        moment = datetime.fromisoformat(text)
    except ValueError:
        raise SearchError(f"{text!r} is not a timestamp") from None
    return moment if moment.tzinfo is not None else moment.replace(tzinfo=UTC)
