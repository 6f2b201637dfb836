"""Page tokens and page sizes, as the API's list endpoints take and return them."""

from __future__ import annotations

import base64
import binascii
import zlib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Generic, TypeVar

T = TypeVar("T")

# The spec's `pageSize` maximum: larger sizes are refused (400), as the spec says. Below it
# the server may still serve smaller pages than asked (`max_page_size`).
SPEC_MAX_PAGE_SIZE = 100


class PagingError(ValueError):
    """A pageSize or pageToken the API would answer with 400."""


@dataclass(frozen=True, slots=True)
class Page(Generic[T]):
    items: Sequence[T]
    next_token: str  # "" on the last page, as the real API ends a list
    total: int


def _list_tag(list_key: str) -> int:
    return zlib.crc32(list_key.encode())


def encode_token(offset: int, list_key: str) -> str:
    # Opaque to clients, but bound to the list it came from so that a token reused on
    # another list is refused instead of silently skipping items.
    raw = f"{offset}:{_list_tag(list_key):08x}".encode()
    return base64.urlsafe_b64encode(raw).decode().rstrip("=")


def decode_token(token: str, list_key: str) -> int:
    try:
        raw = base64.urlsafe_b64decode(token + "=" * (-len(token) % 4)).decode()
        offset_text, tag = raw.split(":")
        offset = int(offset_text)
    except (binascii.Error, UnicodeDecodeError, ValueError):
        raise PagingError(f"malformed pageToken {token!r}") from None
    if offset < 0 or tag != f"{_list_tag(list_key):08x}":
        raise PagingError(f"pageToken {token!r} does not belong to this list")
    return offset


def page_size(query: Mapping[str, str], *, default: int, maximum: int) -> int:
    text = query.get("pageSize")
    if text is None or text == "":
        return default
    try:
        size = int(text)
    except ValueError:
        raise PagingError(f"pageSize {text!r} is not an integer") from None
    if size < 0:
        raise PagingError(f"pageSize {size} is negative")
    if size > SPEC_MAX_PAGE_SIZE:
        raise PagingError(f"pageSize {size} is above the maximum of {SPEC_MAX_PAGE_SIZE}")
    # Like the real API: 0 means the default; a server may serve fewer than asked.
    return default if size == 0 else min(size, maximum)


def paginate(
    items: Sequence[T], query: Mapping[str, str], list_key: str, *, default: int, maximum: int
) -> Page[T]:
    size = page_size(query, default=default, maximum=maximum)
    token = query.get("pageToken") or ""
    offset = decode_token(token, list_key) if token else 0
    if offset > len(items):
        raise PagingError(f"pageToken {token!r} is past the end of the list")
    end = offset + size
    next_token = encode_token(end, list_key) if end < len(items) else ""
    return Page(items[offset:end], next_token, len(items))
