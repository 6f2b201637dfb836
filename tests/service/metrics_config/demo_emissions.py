"""Emissions for ReSim's published demo configs, written by ReSim's own `Emitter` (the
oracle, which checks every row against the config's topics).

The demos' own data is a download; these rows are made from each topic's schema instead
(every column of its type, a few rows a job, different per job), with the values the
configs' queries look for where a generic value would find nothing (a stage named
'handover complete', a session 7 s long), so that every metric of every level has data.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

import yaml
from resim.sdk.metrics.emissions import Emitter

from tests.service.metrics_config.emitted import PNG

ROWS = 4
# Values the demos' queries select on, by (topic, column): one per row, cycled.
CHOSEN: dict[tuple[str, str], list[Any]] = {
    ("stage_timing", "stage"): ["right gripper contact", "lifted", "handover complete"],
    ("task_stage", "state"): ["approach", "lifted", "handover complete"],
    ("goal_status", "state"): ["planning", "driving", "reached"],
    ("session_summary", "total_duration_s"): [7.0],
    ("motion_phase", "kind"): ["moving", "stopped"],
    ("mission", "has_gnss"): [1],
    ("robot_pose", "has_enu"): [1],
    ("robot_pose", "mission_idx"): [0, 1],
    ("gnss_track", "mission_idx"): [0, 1],
    ("session_events", "name"): ["Mission start", "Speed tracking excursion"],
}


@dataclass(frozen=True)
class Demo:
    name: str
    config: Path
    templates: Path


def demo(package: str, config: str) -> Demo:
    data = Path(str(resources.files(package) / "data"))
    return Demo(f"{package}:{config}", data / config, data / "templates")


def _figure(k: int) -> str:
    trace = {"type": "scatter", "mode": "lines", "x": [0, 1, 2], "y": [k, k + 1, k + 3]}
    return json.dumps({"data": [trace], "layout": {"title": {"text": f"job {k}"}}})


def _value(topic: str, column: str, kind: str, k: int, i: int) -> Any:
    chosen = CHOSEN.get((topic, column))
    if chosen is not None:
        return chosen[i % len(chosen)]
    if column == "raw_metric":
        return _figure(k)
    return {
        "int": i + k,
        "float": 0.25 + 1.5 * i + 0.5 * k,
        "boolean": i % 2 == 0,
        "string": f"{column}-{i % 2}",
        "status": ("PASSED", "FAIL_WARN")[i % 2],
        "image": f"{topic}_{column}_{k}.png",
        "video": f"{topic}_{column}_{k}.mp4",
        "string[]": [f"{column}-{i}"],
        "metric[]": [{"name": f"{column} {i}", "type": "scalar", "value": 0.5 * i, "unit": "s"}],
    }[kind]


def emit_demo_job(folder: Path, config: Path, k: int, meta: dict[str, Any] | None = None) -> Path:
    """Job k's emissions for `config` (and its attached files, and job.json when `meta`
    is given) in `folder`; the emissions file's path."""
    folder.mkdir(parents=True, exist_ok=True)
    doc = yaml.safe_load(config.read_text(encoding="utf-8"))
    path = folder / "emissions.resim.jsonl"
    with Emitter(config_path=config, output_path=path) as emitter:
        for topic, body in doc["topics"].items():
            schema: dict[str, str] = body["schema"]
            # A figure the test drew, a summary: one row a job, as the demos emit them.
            rows = 1 if "raw_metric" in schema or "summary" in topic else ROWS
            for i in range(rows):
                row = {c: _value(topic, c, t, k, i) for c, t in schema.items()}
                for c, t in schema.items():
                    if t in ("image", "video"):
                        (folder / row[c]).write_bytes(PNG if t == "image" else b"\0\0\0\x18ftyp")
                at = 1_000_000_000 * i + 250_000_000 * k
                if body.get("event"):
                    emitter.emit_event(topic, row, timestamp=at)
                else:
                    emitter.emit(topic, row, timestamp=at)
    if meta is not None:
        (folder / "job.json").write_text(json.dumps(meta), encoding="utf-8")
    return path
