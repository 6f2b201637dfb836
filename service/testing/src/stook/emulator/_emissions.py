"""What the emulated tests emitted: a `config.resim.yml` and each job's emissions log.

The platform's config-defined metrics read rows that tests emit to named topics
(`emissions.resim.jsonl`, one JSON object a line, uploaded as the job's EMISSIONS_LOG).
The emulated project has a config (`CONFIG_YAML`) and every job that ran emits rows to its
topics, derived from (seed, batch, job index) alone: equal seeds give equal bytes. Jobs
that died before writing metrics (cancelled, and most errors) have no emissions log.

`job_rows` is the ground truth: tests compute what a config metric should show from it
in plain Python; `job_emissions` is the same rows as the file the platform serves.
"""

from __future__ import annotations

import hashlib
import random
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

import orjson

from stook.emulator._world import JobSpec

__all__ = [
    "CONFIG_YAML",
    "EMISSIONS_FILE",
    "EMISSIONS_TEMPLATES",
    "OBJECT_CLASSES",
    "PLANNER_STATES",
    "EmissionsStore",
    "EmittedLog",
    "Row",
    "emissions_bytes",
    "job_rows",
    "write_emissions_config",
]

EMISSIONS_FILE: Final = "emissions.resim.jsonl"
OBJECT_CLASSES: Final = ("car", "pedestrian", "cyclist", "truck")
PLANNER_STATES: Final = ("CRUISE", "FOLLOW", "YIELD", "STOP")
_EVENT_NAMES: Final = ("Hard brake", "Near miss")
# A frame every 100 ms of simulated time, as timestamps in nanoseconds.
_FRAME_NS: Final = 100_000_000

# The emulated project's `.resim/metrics/config.resim.yml`: topics (one of them an event
# topic), metrics at the three levels (image metrics and a custom template among them),
# two metrics sets and a dashboard, written the way ReSim's documentation and public
# example configs write them.
CONFIG_YAML: Final = """\
version: 1

topics:
  localization:
    schema:
      frame: int
      error: float
  vehicle:
    schema:
      speed: float
      acceleration: float
  detections:
    schema:
      object_class: string
      count: int
  planner_state:
    schema:
      state: string
  run_summary:
    schema:
      distance: float
      collisions: int
      completed: boolean
  camera:
    schema:
      frame: int
      error: float
      snapshot: image
  safety_events:
    event: true
    schema:
      name: string
      description: string
      status: status
      tags: string[]
      metrics: metric[]

metrics:
  # ---- test level ----
  Localization error over time:
    type: test
    description: The localization error at each frame
    query_string: |
      SELECT 'error' AS series, timestamp / 1E9 AS "Time (s)", error AS "Error (m)"
      FROM localization ORDER BY timestamp
    template_type: system
    template: line
  Max localization error:
    type: test
    description: The worst localization error of the run
    query_string: SELECT MAX(error) AS value FROM localization
    template_type: system
    template: scalar
    units: m
    status:
      query_string: SELECT 1 FROM localization HAVING MAX(error) > ?
      block: 1.5
      warn: 1.0
  Planner states:
    type: test
    query_string: |
      SELECT 'planner' AS system, timestamp, state FROM planner_state ORDER BY timestamp
    template_type: system
    template: state_timeline
  Safety events:
    type: test
    query_string: SELECT COUNT(*) AS value FROM safety_events
    template_type: system
    template: scalar
    skip_if_no_data: false

  # ---- batch level ----
  Mean localization error:
    type: batch
    description: The mean localization error over every frame of every job
    query_string: SELECT AVG(error) AS value FROM localization
    template_type: system
    template: scalar
    units: m
    status:
      query_string: SELECT 1 FROM localization HAVING AVG(error) > ?
      block: 2.0
      warn: 0.8
  Localization error per experience:
    type: batch
    query_string: |
      SELECT experience_name AS "Experience",
             COUNT(*) AS "Frames",
             ROUND(MAX(error), 4) AS "Max error (m)"
      FROM localization
      GROUP BY experience_name
      ORDER BY experience_name
    template_type: system
    template: table
  Detections per class:
    type: batch
    query_string: |
      SELECT object_class AS category, SUM(count) AS value
      FROM detections GROUP BY object_class ORDER BY object_class
    template_type: system
    template: bar
  Speed distribution:
    type: batch
    query_string: SELECT speed AS "Speed (m/s)" FROM vehicle
    template_type: system
    template: histogram
    template_settings:
      display:
        bins: 20
  Job outcomes:
    type: batch
    query_string: |
      SELECT job_conflated_status AS label, COUNT(*) AS value
      FROM metadata GROUP BY job_conflated_status ORDER BY job_conflated_status
    template_type: system
    template: pie
  Jobs with collisions:
    type: batch
    query_string: SELECT COUNT_IF(collisions > 0) AS value FROM run_summary
    template_type: system
    template: scalar
    skip_if_no_data: false
    status:
      query_string: SELECT 1 FROM run_summary HAVING COUNT_IF(collisions > 0) > ?
      block: 10
      warn: 0
  Total distance driven:
    type: batch
    query_string: SELECT SUM(distance) AS value FROM run_summary
    template_type: system
    template: scalar
    units: m
  Hard brakes per job:
    type: batch
    query_string: |
      SELECT m.experience_name AS "Experience", COUNT(*) AS "Hard brakes"
      FROM safety_events e JOIN metadata m ON e.job_id = m.job_id
      WHERE e.name = 'Hard brake'
      GROUP BY m.experience_name ORDER BY m.experience_name
    template_type: system
    template: table
  Teleports:
    type: batch
    query_string: SELECT COUNT(*) AS value FROM localization WHERE error > 1000 HAVING COUNT(*) > 0
    template_type: system
    template: scalar
    skip_if_no_data: true
  Worst localization frame:
    type: batch
    description: The camera frame of the largest localization error of the batch
    query_string: SELECT snapshot FROM camera ORDER BY error DESC, job_id LIMIT 1
    template_type: system
    template: image
  Mean speed per experience:
    type: batch
    query_string: |
      SELECT experience_name AS x, AVG(speed) AS y
      FROM vehicle GROUP BY experience_name ORDER BY experience_name
    template_type: custom
    template_file: bar_figure.liquid

  # ---- dashboard level ----
  Mean localization error by build:
    type: dashboard
    query_string: |
      SELECT build_version AS category, AVG(error) AS value
      FROM localization GROUP BY build_version ORDER BY build_version
    template_type: system
    template: bar
  Collisions by build:
    type: dashboard
    query_string: |
      SELECT build_version AS "Build", SUM(collisions) AS "Collisions"
      FROM run_summary GROUP BY build_version ORDER BY build_version
    template_type: system
    template: table
  Mean speed by build:
    type: dashboard
    query_string: |
      SELECT build_version AS x, AVG(speed) AS y
      FROM vehicle GROUP BY build_version ORDER BY build_version
    template_type: custom
    template_file: bar_figure.liquid
  Worst localization frame of the builds:
    type: dashboard
    query_string: SELECT snapshot FROM camera ORDER BY error DESC, job_id LIMIT 1
    template_type: system
    template: image

metrics sets:
  nightly:
    metrics:
      - Mean localization error
      - Job outcomes
      - Jobs with collisions
  trends:
    metrics:
      - Mean localization error by build
      - Collisions by build

dashboards:
  Nightly trends:
    metrics_set: trends
    refresh: auto
    day_range: 90
"""

# The custom templates of the config, by file name: they live in `templates/` beside it.
EMISSIONS_TEMPLATES: Final = {
    # A bar per row: the query's columns `x` (the bars' labels) and `y` (their heights).
    "bar_figure.liquid": """\
{"data": [{"type": "bar", "x": {{ x | json }}, "y": {{ y | json }}}],
 "layout": {"yaxis": {"title": {"text": "Mean speed (m/s)"}}}}
""",
}


def write_emissions_config(folder: Path, text: str = CONFIG_YAML) -> Path:
    """Write `text` (default: the world's config) as `folder/config.resim.yml` and the
    custom templates into `folder/templates/`, where stook looks by default; the config's
    path."""
    (folder / "templates").mkdir(parents=True, exist_ok=True)
    for name, template in EMISSIONS_TEMPLATES.items():
        (folder / "templates" / name).write_text(template, encoding="utf-8")
    config = folder / "config.resim.yml"
    config.write_text(text, encoding="utf-8")
    return config


@dataclass(frozen=True, slots=True)
class Row:
    """One emitted line: its topic, timestamp (ns), whether it is an event, its columns."""

    topic: str
    timestamp: int
    data: dict[str, Any]
    event: bool = False

    def line(self) -> dict[str, Any]:
        metadata: dict[str, Any] = {"topic": self.topic, "timestamp": self.timestamp}
        if self.event:
            metadata["event"] = True
        return {"$metadata": metadata, "$data": self.data}


def has_emissions(job: JobSpec) -> bool:
    """Whether a job uploaded an emissions log: those that ran to their metrics did."""
    return job.has_metrics


def job_rows(seed: int, job: JobSpec, frames: int) -> list[Row] | None:
    """What a job emitted, in emission order; None when it has no emissions log."""
    if not has_emissions(job):
        return None
    rng = random.Random(f"{seed}:emissions:{job.batch_id}:{job.index}")
    rows: list[Row] = []
    # A harder experience drifts more; a failing job drifts more still.
    drift = 0.2 + 0.05 * (job.experience.index % 7)
    if job.conflated_status in ("WARNING", "BLOCKER"):
        drift *= 2.5
    error = 0.0
    worst = (-1.0, 0)  # the largest error and its frame: the camera's snapshot
    speed = rng.uniform(8.0, 14.0)
    state = "CRUISE"
    for frame in range(frames):
        t = frame * _FRAME_NS
        error = abs(error + rng.gauss(0.0, 0.05 * drift)) * 0.98 + 0.01 * drift
        rows.append(Row("localization", t, {"frame": frame, "error": round(error, 6)}))
        if round(error, 6) > worst[0]:
            worst = (round(error, 6), frame)
        acceleration = round(rng.gauss(0.0, 1.2), 4)
        speed = max(0.0, speed + acceleration * 0.1)
        rows.append(Row("vehicle", t, {"speed": round(speed, 4), "acceleration": acceleration}))
        if frame % 10 == 0 and (frame == 0 or rng.random() < 0.4):
            state = PLANNER_STATES[0] if frame == 0 else rng.choice(PLANNER_STATES)
            rows.append(Row("planner_state", t, {"state": state}))
    end = frames * _FRAME_NS
    for object_class in OBJECT_CLASSES:
        # A class a job never saw is not emitted at all (not a zero count).
        count = rng.randint(0, 12)
        if count:
            rows.append(Row("detections", end, {"object_class": object_class, "count": count}))
    for name in _EVENT_NAMES:
        if rng.random() < 0.3:
            at = rng.randrange(frames or 1) * _FRAME_NS
            rows.append(
                Row(
                    "safety_events",
                    at,
                    {
                        "name": name,
                        "description": f"{name} at {at / 1e9:.1f} s",
                        "status": "FAIL_WARN" if name == "Near miss" else "PASSED",
                        "tags": ["safety", "longitudinal"],
                        "metrics": [
                            {"name": "speed", "type": "scalar", "value": round(speed, 3)},
                        ],
                    },
                    event=True,
                )
            )
    collisions = 1 if job.conflated_status == "BLOCKER" and rng.random() < 0.5 else 0
    distance = round(speed * frames * 0.1 + rng.uniform(0.0, 5.0), 3)
    rows.append(
        Row(
            "run_summary",
            end,
            {
                "distance": distance,
                "collisions": collisions,
                "completed": job.job_status == "SUCCEEDED",
            },
        )
    )
    if frames:
        # Derived from the rows above, drawing nothing from `rng`: the other rows are
        # the same with or without it.
        snapshot = {"frame": worst[1], "error": worst[0], "snapshot": f"frame_{worst[1]:04d}.png"}
        rows.append(Row("camera", worst[1] * _FRAME_NS, snapshot))
    return rows


def emissions_bytes(rows: list[Row]) -> bytes:
    """The rows as the emissions file: one JSON object a line."""
    return b"".join(orjson.dumps(r.line()) + b"\n" for r in rows)


@dataclass(frozen=True, slots=True)
class EmittedLog:
    """A job's emissions log as stored: its bytes and what the listing says of them."""

    body: bytes
    checksum: str  # hex MD5, as S3 ETags of single-part uploads are


class EmissionsStore:
    """Each job's emissions log, regenerated on demand; the most recently used kept (a
    listing and the download that follows it read the same job)."""

    def __init__(self, seed: int, frames: int, keep: int) -> None:
        self._seed = seed
        self._frames = frames
        self._keep = keep
        self._logs: OrderedDict[tuple[Any, int], EmittedLog] = OrderedDict()

    def log(self, job: JobSpec) -> EmittedLog | None:
        if not has_emissions(job):
            return None
        key = (job.batch_id, job.index)
        found = self._logs.get(key)
        if found is not None:
            self._logs.move_to_end(key)
            return found
        rows = job_rows(self._seed, job, self._frames)
        assert rows is not None
        body = emissions_bytes(rows)
        found = EmittedLog(body, hashlib.md5(body, usedforsecurity=False).hexdigest())
        self._logs[key] = found
        if len(self._logs) > self._keep:
            self._logs.popitem(last=False)
        return found

    def rows(self, job: JobSpec) -> list[Row] | None:
        return job_rows(self._seed, job, self._frames)
