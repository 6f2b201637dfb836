"""A candidate/baseline pair for batch mode's `[batch.baseline]` comparison.

With `baseline_pair`, the world gains a finished batch (kind BASELINE) of the main
batch's test suite and branch, created six hours before it, so that `previous = true`
and `branch = "main"` both find it. Both batches run the same experiences in the same
job slots, and what a job writes is that experience's level plus a little per-run
noise, so pairing by experience is what a real rerun would allow. The main batch then
differs in exactly two seeded ways:

- the experiences `baseline_regressed_experiences` (indices) pass in the baseline and
  fail (WARNING, from "Lane departures") in the main batch; every other experience keeps
  its outcome;
- `baseline_shift_metric` is `1 + baseline_shift` times its baseline level.

Every other scalar is drawn from the same distribution in both batches: no change.
"""

from __future__ import annotations

import random
import uuid
from datetime import datetime, timedelta
from typing import TYPE_CHECKING

from stook.sdk import MetricStatus, MetricsWriter

if TYPE_CHECKING:
    from stook.emulator._generate import WrittenMetrics
    from stook.emulator._world import BatchSpec, JobSpec, World

#: The scalars a pair job writes: unit, and the limit it fails above (None: none).
PAIR_SCALARS: dict[str, tuple[str | None, float | None]] = {
    "Localization error": ("m", 0.3),
    "Max speed": ("m/s", None),
    "Distance driven": ("m", None),
    "Collisions": (None, 0.0),
    "Lane departures": (None, 0.5),
}
BRANCH_NAMES = ("main", "feature/planner-tuning")


def baseline_batch(world: World, main_created: datetime) -> BatchSpec | None:
    """The pair's baseline batch, or None when the config asks for no pair."""
    from stook.emulator._world import BatchKind, BatchSpec

    c = world.config
    if not c.baseline_pair:
        return None
    created = main_created - timedelta(hours=6)
    return BatchSpec(
        world._id("batch:baseline"),
        BatchKind.BASELINE,
        0,
        "nightly-baseline",
        created,
        c.jobs_per_batch,
        world.test_suite_id,
        max(1, 2 if c.report_batches // 3 > 0 else 1),
        world.branch_id,
        world._build("baseline", f"1.{c.report_batches}.0-rc", world.branch_id, created),
        "SUCCEEDED",
        1.0,
    )


def in_pair(world: World, batch: BatchSpec) -> bool:
    from stook.emulator._world import BatchKind

    return world.config.baseline_pair and batch.kind in (BatchKind.MAIN, BatchKind.BASELINE)


def pair_job(world: World, batch: BatchSpec, i: int) -> JobSpec:
    """Job slot `i` of a pair batch: its outcome depends on the slot, not on the batch,
    except for the regressed experiences."""
    from stook.emulator._world import BatchKind, JobSpec

    experience = world.experiences[i % len(world.experiences)]
    u = random.Random(f"{world.seed}:pair-slot:{i}").random()
    if experience.index in world.config.baseline_regressed_experiences:
        conflated = "WARNING" if batch.kind is BatchKind.MAIN else "PASSED"
    elif u < 0.08:
        conflated = "BLOCKER"
    elif u < 0.18:
        conflated = "WARNING"
    else:
        conflated = "PASSED"
    metrics_status = {"PASSED": "PASSED", "WARNING": "FAIL_WARN", "BLOCKER": "FAIL_BLOCK"}
    return JobSpec(
        uuid.uuid5(world._ns, f"job:{batch.id}:{i}"),
        batch.id,
        i,
        experience,
        conflated,
        "SUCCEEDED",
        metrics_status[conflated],
        True,
        batch.created + timedelta(milliseconds=50 * i),
        batch.build_id,
    )


def generate_pair_job(world: World, job: JobSpec, batch: BatchSpec) -> WrittenMetrics:
    """A pair job's scalars: the experience's level, per-run noise, the seeded shift."""
    from stook.emulator._generate import TruthBuilder, WrittenMetrics
    from stook.emulator._world import BatchKind

    c = world.config
    level = random.Random(f"{world.seed}:pair-level:{job.experience.index}")
    noise = random.Random(f"{world.seed}:pair-noise:{job.id}")
    slot = random.Random(f"{world.seed}:pair-slot-values:{job.index}")
    values = {
        "Localization error": level.uniform(0.08, 0.16) + noise.gauss(0.0, 0.01),
        "Max speed": level.uniform(10.0, 25.0) + noise.gauss(0.0, 0.5),
        "Distance driven": level.uniform(300.0, 900.0) + noise.gauss(0.0, 10.0),
        "Collisions": float(slot.randint(1, 3)) if job.conflated_status == "BLOCKER" else 0.0,
        "Lane departures": float(slot.randint(1, 2)) if job.conflated_status == "WARNING" else 0.0,
    }
    if batch.kind is BatchKind.MAIN and c.baseline_shift_metric in values:
        values[c.baseline_shift_metric] *= 1.0 + c.baseline_shift
    writer = MetricsWriter(job.id, deterministic=True)
    truth = TruthBuilder()
    for name, (unit, limit) in PAIR_SCALARS.items():
        value = values[name]
        failed = limit is not None and value > limit
        status = MetricStatus.PASSED
        if failed:
            status = MetricStatus.FAIL_BLOCK if name == "Collisions" else MetricStatus.FAIL_WARN
        writer.scalar(
            name,
            value,
            unit=unit,
            status=status,
            fails_above=limit,
            blocking=name == "Collisions",
        )
        truth.scalars[name] = value
        truth.units[name] = unit or ""
    return WrittenMetrics(writer, truth)


def branches(world: World) -> list[tuple[uuid.UUID, str]]:
    """The project's branches (ID, name), as the branches listing serves them."""
    return list(zip((world.branch_id, world.feature_branch_id), BRANCH_NAMES, strict=True))
