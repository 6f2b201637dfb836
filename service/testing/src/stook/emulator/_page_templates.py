"""A listing page's JSON bytes with a hole for each presigned URL, serialized once.

A page of a job's metric listing is the same bytes at every request but for its
presigned URLs, which carry the time they were signed. Report mode lists every job's
metrics (thousands of listings a run), and building each page's JSON objects anew was
most of the emulator's CPU per listing, on a benchmark machine whose two cores it shares
with the client it serves. So a page is built and serialized once, with a placeholder
string for each URL; each answer signs its URLs and puts their JSON into the holes. That
is the bytes serializing the whole page would give: orjson writes a string the same
wherever it stands in a document.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Any, Final

import orjson

# Where a URL goes; control characters that no name, ID or timestamp holds (a page whose
# holes do not match its URLs one for one is not made into a template).
PLACEHOLDER: Final = "\x00presigned URL\x00"
_HOLE: Final = orjson.dumps(PLACEHOLDER)


@dataclass(frozen=True, slots=True)
class PageTemplate:
    """A page's bytes around its URLs' holes, and the storage path of each URL, in order."""

    parts: tuple[bytes, ...]
    paths: tuple[str, ...]

    @classmethod
    def of(cls, body: Any, paths: Iterable[str]) -> PageTemplate | None:
        """`body` (a page with `PLACEHOLDER` for each URL, in the order of `paths`) as a
        template; None when its placeholders are not one per path."""
        paths = tuple(paths)
        parts = tuple(orjson.dumps(body).split(_HOLE))
        return cls(parts, paths) if len(parts) == len(paths) + 1 else None

    def fill(self, urls: Iterable[str]) -> bytes:
        """The page's bytes with `urls` (one per path) in its holes."""
        parts = self.parts
        out = [parts[0]]
        for url, part in zip(urls, parts[1:], strict=True):
            out.append(orjson.dumps(url))
            out.append(part)
        return b"".join(out)
