"""How the writer names things: random UUIDs, or UUIDs derived from names.

Derived IDs make the same input give byte-identical output, which is what
tests, caches and reproducible batch runs want.
"""

from __future__ import annotations

import uuid
from collections import Counter

_STOOK_NAMESPACE = uuid.UUID("5d1f3c8e-6a0b-4c2e-9f3a-7b1e2d4c6a80")


class IdScheme:
    """Hands out metric, data and event IDs for one output."""

    def __init__(self, job_id: uuid.UUID, *, deterministic: bool) -> None:
        self.deterministic = deterministic
        self._namespace = uuid.uuid5(_STOOK_NAMESPACE, str(job_id))
        self._uses: Counter[str] = Counter()

    def _derive(self, kind: str, name: str) -> uuid.UUID:
        key = f"{kind}:{name}"
        self._uses[key] += 1
        n = self._uses[key]
        # Event metrics may share a name; the counter keeps their IDs apart, in its own
        # prefix so that no name can spell another's repeat ("a#2" is not "a", twice).
        return uuid.uuid5(self._namespace, key if n == 1 else f"{kind}#{n}:{name}")

    def metric_id(self, name: str) -> uuid.UUID:
        return self._derive("metric", name) if self.deterministic else uuid.uuid4()

    def event_id(self, name: str) -> uuid.UUID:
        return self._derive("event", name) if self.deterministic else uuid.uuid4()

    def data_id(self, name: str, own_id: uuid.UUID) -> uuid.UUID:
        return uuid.uuid5(self._namespace, f"data:{name}") if self.deterministic else own_id
