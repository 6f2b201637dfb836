"""Bytes of the partial states that travel between processes: what a shard sends back.

The processes and Ray engines fold each shard of a batch's jobs into fresh partial states
in a worker and pickle them back to the driver, which merges them. This folds synthetic
`JobRecord`s (shaped like the emulator's jobs: four SCALAR metrics, a ``speeds`` series of
50-500 doubles, six metric statuses) into the default batch aggregations, a histogram of
``speeds`` as the benchmark config has it (counts mode past 10,000 values) and the batch
summary, split into shards, and reports each aggregation's pickled bytes per shard. It
measures sizes, not time, so the machine's load does not matter.

    .venv/bin/python -m stook.bench._state_bytes --jobs 20000 --shards 2
"""

from __future__ import annotations

import argparse
import pickle
import random
import uuid
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

from stook.sdk.aggregations import (
    Aggregation,
    BatchSummaryWriter,
    JobRecord,
    MergedHistogram,
    Scalar,
    default_batch_aggregations,
)

SCALARS = (
    ("Localization error", "m"),
    ("Distance driven", "m"),
    ("Max speed", "m/s"),
    ("Braking distance", "m"),
)
STATUSES = ("PASSED", "PASSED", "PASSED", "WARNING", "BLOCKER", "ERROR")
METRIC_STATUSES = ("PASSED", "PASSED", "FAIL_WARN", "RAW", "RAW", "NOT_APPLICABLE")


def synthetic_jobs(count: int, *, seed: int = 7) -> list[JobRecord]:
    """`count` jobs with the emulator's shape; the same `seed`, the same jobs."""
    import polars as pl

    rng = random.Random(seed)
    jobs = []
    for i in range(count):
        n = rng.randint(50, 500)
        cruise = rng.uniform(8.0, 28.0)
        speeds = [max(0.0, cruise + rng.uniform(-6.0, 6.0)) for _ in range(n)]
        jobs.append(
            JobRecord(
                job_id=uuid.UUID(int=rng.getrandbits(128)),
                conflated_status=rng.choice(STATUSES),
                experience_name=f"experience {i % 200}",
                experience_id=uuid.UUID(int=i % 200 + 1),
                scalars={name: Scalar(rng.uniform(0.0, 2000.0), unit) for name, unit in SCALARS},
                series={"speeds": pl.Series("speeds", speeds, dtype=pl.Float64)},
                metric_statuses=METRIC_STATUSES,
            )
        )
    return jobs


def measured_aggregations() -> list[Aggregation[Any]]:
    """The default batch aggregations, the benchmark's histogram and the batch summary."""
    return [
        *default_batch_aggregations(),
        MergedHistogram(
            name="Speeds", data="speeds", lower=0.0, upper=40.0, buckets=20, max_values=10_000
        ),
        BatchSummaryWriter(),
    ]


@dataclass(frozen=True, slots=True)
class StateBytes:
    """One aggregation's pickled partial state in each shard (bytes), and its jobs."""

    aggregation: str
    shard_bytes: tuple[int, ...]
    shard_jobs: tuple[int, ...]

    @property
    def bytes_per_job(self) -> float:
        return sum(self.shard_bytes) / max(1, sum(self.shard_jobs))


def shards_of(jobs: Sequence[JobRecord], shards: int) -> list[Sequence[JobRecord]]:
    """Consecutive runs of jobs, as an engine splits a batch's job list."""
    size = -(-len(jobs) // shards)
    return [jobs[i * size : (i + 1) * size] for i in range(shards)]


def state_bytes(
    jobs: Sequence[JobRecord],
    shards: int = 2,
    aggregations: Callable[[], list[Aggregation[Any]]] = measured_aggregations,
) -> list[StateBytes]:
    """Fold each shard of `jobs` into fresh `aggregations` and pickle each partial as an
    engine sends it (highest protocol); a row per aggregation, then one for them all."""
    per_shard: list[list[int]] = []
    totals: list[int] = []
    parts = shards_of(jobs, shards)
    names = [_label(a) for a in aggregations()]
    for part in parts:
        partials = aggregations()
        for record in part:
            for partial in partials:
                partial.update(record)
        per_shard.append([len(pickle.dumps(p, pickle.HIGHEST_PROTOCOL)) for p in partials])
        totals.append(len(pickle.dumps(partials, pickle.HIGHEST_PROTOCOL)))
    counts = tuple(len(part) for part in parts)
    rows = [
        StateBytes(name, tuple(sizes[i] for sizes in per_shard), counts)
        for i, name in enumerate(names)
    ]
    rows.append(StateBytes("all of them, pickled together", tuple(totals), counts))
    return rows


def _label(aggregation: Aggregation[Any]) -> str:
    return f"{type(aggregation).__name__} ({aggregation.name})"


def table(rows: Sequence[StateBytes]) -> str:
    """The rows as a Markdown table: bytes per shard and per job."""
    shards = len(rows[0].shard_bytes) if rows else 0
    head = ["Aggregation", *(f"shard {i + 1} (bytes)" for i in range(shards)), "bytes per job"]
    lines = ["| " + " | ".join(head) + " |", "|---" + "|--:" * (len(head) - 1) + "|"]
    for row in rows:
        cells = [row.aggregation, *(f"{b:,}" for b in row.shard_bytes), f"{row.bytes_per_job:.2f}"]
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m stook.bench._state_bytes", description=__doc__.splitlines()[0]
    )
    parser.add_argument("--jobs", type=int, default=20_000)
    parser.add_argument("--shards", type=int, default=2)
    args = parser.parse_args(argv)
    if args.jobs < 1 or args.shards < 1:
        parser.error("--jobs and --shards must be at least 1")
    rows = state_bytes(synthetic_jobs(args.jobs), args.shards)
    print(f"{args.jobs:,} synthetic jobs in {args.shards} shards:\n")
    print(table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
