"""Emission files written by ReSim's own `Emitter` (the oracle), and the plain data
they hold, from which the tests compute every metric's expected numbers in Python."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from resim.sdk.metrics.emissions import Emitter

# The smallest valid PNG (1x1): an attached file the image metric references.
PNG = bytes.fromhex(
    "89504e470d0a1a0a0000000d49484452000000010000000108060000001f15c489"
    "0000000d49444154789c6360000002000001e221bc330000000049454e44ae426082"
)


@dataclass
class JobData:
    """What one job emitted, as plain Python."""

    name: str
    speed: list[tuple[str, int, float]] = field(default_factory=list)  # lane, ns, speed
    detections: list[tuple[str, int, bool]] = field(default_factory=list)
    states: list[tuple[int, str]] = field(default_factory=list)
    frame: str = ""
    collisions: list[dict[str, Any]] = field(default_factory=list)


def make_job(k: int) -> JobData:
    """Job k's data: deterministic, different per job."""
    job = JobData(name=f"experience-{k}")
    for lane, offset in (("left", 0.0), ("right", 2.5)):
        for i in range(6):
            job.speed.append((lane, i * 500_000_000, 8.0 + 7 * k + offset + 1.5 * i - 0.25 * i * i))
    for i, label in enumerate(["car", "pedestrian", "car", "cyclist", "car"]):
        job.detections.append((label, (i + 1) * (k + 1), i % 2 == 0))
    job.states = [(0, "cruise"), (1_000_000_000, "yield"), (2_000_000_000 + k, "cruise")]
    job.frame = f"frame_{k}.png"
    if k == 0:
        job.collisions.append(
            {
                "name": "rear contact",
                "description": "contact at low speed",
                "status": "FAIL_WARN",
                "tags": ["contact", "rear"],
                "metrics": [
                    {"name": "impact speed", "type": "scalar", "value": 3.5, "unit": "m/s"}
                ],
            }
        )
    return job


def emit_job(folder: Path, config: Path, job: JobData, meta: dict[str, Any] | None = None) -> Path:
    """Write the job's emissions with ReSim's Emitter (validating against `config`), its
    attached frame, and job.json when `meta` is given. The emissions file's path."""
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "emissions.resim.jsonl"
    with Emitter(config_path=config, output_path=path) as emitter:
        for lane in ("left", "right"):
            points = [(t, s) for ln, t, s in job.speed if ln == lane]
            emitter.emit_series(
                "speed",
                {"lane": [lane] * len(points), "speed": [s for _, s in points]},
                timestamps=[t for t, _ in points],
            )
        for label, count, confident in job.detections:
            emitter.emit("detections", {"label": label, "count": count, "confident": confident})
        for at, state in job.states:
            emitter.emit("planner_state", {"state": state}, timestamp=at)
        emitter.emit("camera", {"frame": job.frame})
        for i, collision in enumerate(job.collisions):
            emitter.emit_event("collision", collision, timestamp=1_500_000_000 + i)
    (folder / job.frame).write_bytes(PNG)
    if meta is not None:
        (folder / "job.json").write_text(json.dumps(meta), encoding="utf-8")
    return path
