"""What the emulator saw: counters for tests and benchmarks."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any


@dataclass
class EmulatorStats:
    """Counters keyed by origin ("api", "storage") or "origin:detail"."""

    requests: Counter[str] = field(default_factory=Counter)  # per origin
    endpoints: Counter[str] = field(default_factory=Counter)  # "api:list_jobs", ...
    # API requests per path (no query), e.g. to check that a client asks for each
    # experience's tags once: "/v1/projects/<p>/experiences/<e>/experienceTags".
    api_paths: Counter[str] = field(default_factory=Counter)
    statuses: Counter[str] = field(default_factory=Counter)  # "api:200", "storage:403", ...
    faults: Counter[str] = field(default_factory=Counter)  # "storage:reset", "api:5xx", ...
    rate_limited: Counter[str] = field(default_factory=Counter)  # per origin
    # The most requests of an origin waiting out their latency at once: concurrency as the
    # server saw it.
    peak_in_latency: Counter[str] = field(default_factory=Counter)
    bytes_served: Counter[str] = field(default_factory=Counter)  # per origin, bodies only
    unauthorized: int = 0  # API requests answered 401
    # Storage requests that carried an Authorization header: a leaked token.
    storage_authorization: list[str] = field(default_factory=list)
    expired_urls: int = 0
    bad_signatures: int = 0
    broken_job_answers: int = 0  # 500s answered for EmulatorConfig.broken_jobs
    outage_refusals: Counter[str] = field(default_factory=Counter)  # 503s of outages, per origin
    # Each outage that began: (origin, start, end), in time.monotonic() seconds.
    outage_windows: list[tuple[str, float, float]] = field(default_factory=list)
    # When the first request arrived, in time.monotonic() seconds (one clock for every
    # process on the machine): `stook bench` times a client's start-up against it.
    first_request_at: float | None = None

    def path_requests(self, suffix: str) -> dict[str, int]:
        """API requests per path ending in `suffix` (e.g. "/experienceTags")."""
        return {p: n for p, n in self.api_paths.items() if p.endswith(suffix)}

    def fault_count(self, kind: str | None = None, origin: str | None = None) -> int:
        total = 0
        for key, n in self.faults.items():
            o, k = key.split(":", 1)
            if (kind is None or k == kind) and (origin is None or o == origin):
                total += n
        return total

    @property
    def leaked_tokens(self) -> int:
        return len(self.storage_authorization)

    def reset(self) -> None:
        fresh = EmulatorStats()
        for name in self.__dataclass_fields__:
            setattr(self, name, getattr(fresh, name))

    def to_dict(self) -> dict[str, Any]:
        return {
            "requests": dict(self.requests),
            "endpoints": dict(self.endpoints),
            "api_paths": dict(self.api_paths),
            "statuses": dict(self.statuses),
            "faults": dict(self.faults),
            "rate_limited": dict(self.rate_limited),
            "peak_in_latency": dict(self.peak_in_latency),
            "bytes_served": dict(self.bytes_served),
            "unauthorized": self.unauthorized,
            "storage_authorization": list(self.storage_authorization),
            "expired_urls": self.expired_urls,
            "bad_signatures": self.bad_signatures,
            "broken_job_answers": self.broken_job_answers,
            "outage_refusals": dict(self.outage_refusals),
            "outage_windows": [list(w) for w in self.outage_windows],
            "first_request_at": self.first_request_at,
        }

    @classmethod
    def from_dict(cls, values: dict[str, Any]) -> EmulatorStats:
        return cls(
            requests=Counter(values.get("requests", {})),
            endpoints=Counter(values.get("endpoints", {})),
            api_paths=Counter(values.get("api_paths", {})),
            statuses=Counter(values.get("statuses", {})),
            faults=Counter(values.get("faults", {})),
            rate_limited=Counter(values.get("rate_limited", {})),
            peak_in_latency=Counter(values.get("peak_in_latency", {})),
            bytes_served=Counter(values.get("bytes_served", {})),
            unauthorized=int(values.get("unauthorized", 0)),
            storage_authorization=list(values.get("storage_authorization", [])),
            expired_urls=int(values.get("expired_urls", 0)),
            bad_signatures=int(values.get("bad_signatures", 0)),
            broken_job_answers=int(values.get("broken_job_answers", 0)),
            outage_refusals=Counter(values.get("outage_refusals", {})),
            outage_windows=[
                (str(o), float(a), float(b)) for o, a, b in values.get("outage_windows", [])
            ],
            first_request_at=values.get("first_request_at"),
        )
