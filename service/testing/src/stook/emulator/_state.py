"""What both origins' handlers share: the data set, the counters and the fault wiring.

One `EmulatorState` per running emulator turns its config into the objects that decide
what a request meets (faults, latency, outages, rate limits, spec quirks, URL signing);
it lives on the server's event loop only.
"""

from __future__ import annotations

import time
import uuid
from collections import Counter

from stook.emulator._config import EmulatorConfig, Origin
from stook.emulator._dataset import Dataset
from stook.emulator._faults import FaultInjector, Latency, OutageSchedule, TokenBucket
from stook.emulator._quirks import SpecQuirks
from stook.emulator._signing import UrlSigner
from stook.emulator._stats import EmulatorStats


class EmulatorState:
    """Everything the handlers share; lives on the server's event loop only."""

    def __init__(self, config: EmulatorConfig, dataset: Dataset | None = None) -> None:
        self.config = config
        self.dataset = dataset or Dataset(config)
        self.stats = EmulatorStats()
        self.faults = FaultInjector(config)
        self.latency = Latency(config)
        self.quirks = SpecQuirks(config)
        self.outages = OutageSchedule(config.outages, time.monotonic())
        self.in_latency: Counter[str] = Counter()  # requests waiting out their latency now
        self.in_flight = 0  # requests of both origins being answered now (max_in_flight)
        self.clock_offset = 0.0
        self.storage_url = ""  # known once the storage site is bound
        # The secret only has to be unguessable by clients, not secret across runs.
        self.signer = UrlSigner(
            uuid.uuid5(self.dataset.project_id, "url-secret").bytes, config.url_lifetime_s
        )
        now = self.now()
        self.buckets: dict[Origin, TokenBucket] = {}
        if config.rate_limit_rps is not None:
            self.buckets["api"] = TokenBucket(config.rate_limit_rps, config.rate_limit_burst, now)
        if config.storage_rate_limit_rps is not None:
            self.buckets["storage"] = TokenBucket(
                config.storage_rate_limit_rps, config.storage_rate_limit_burst, now
            )

    def now(self) -> float:
        return time.time() + self.clock_offset

    def presign(self, path: str) -> str:
        return self.signer.sign(self.storage_url, path, self.now())
