"""What a client's traffic amounted to: requests, retries, bytes, statuses.

Its own module because two parts of the API layer count into it: the transport (requests,
statuses, bytes) and the retry loop (retries and why), neither of which knows the other.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field

__all__ = ["TransferStats"]


@dataclass(slots=True)
class TransferStats:
    """Counters for one client; a single event loop updates them, so no lock is needed."""

    requests: int = 0
    retries: int = 0
    bytes_received: int = 0
    statuses: Counter[int] = field(default_factory=Counter)
    retry_reasons: Counter[str] = field(default_factory=Counter)

    def as_dict(self) -> dict[str, object]:
        return {
            "requests": self.requests,
            "retries": self.retries,
            "bytes_received": self.bytes_received,
            "statuses": dict(sorted(self.statuses.items())),
            "retry_reasons": dict(self.retry_reasons),
        }
