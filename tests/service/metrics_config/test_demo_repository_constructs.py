"""The constructs of ReSim's public demo repositories' configs (getting-started-demo's
drone and ALOHA configs, isaacsim-demo's navigation config and its `report.resim.yml`),
in small configs of our own, over emissions ReSim's own `Emitter` wrote: each value is
the one the platform shows, computed here by hand.

- a batch `video` metric over `SELECT experience_name, job_id ...`: each row's job's
  video, picked by the experience's custom field (`custom_field_values[array_position(
  custom_field_keys, 'Lighting')]`), every job's file kept apart though all are named
  alike;
- a line whose x is text (`date_format(MAX(build_creation_timestamp), ...)` per batch,
  the report's builds within `current_timestamp - interval '3' month`), in a second file
  of `type: report` metrics with `topics: {}`;
- an event topic with `metrics: metric[]` whose FAIL_BLOCK counts toward the test; a
  severity status (`CASE ... END >= ?` with `HAVING`); `ARRAY_JOIN(ARRAY_SORT(
  ARRAY_AGG(DISTINCT ...)))`; a custom template with `case`/`when` and
  `forloop.index0`.
"""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path
from typing import Any

import pytest
from resim.sdk.metrics.emissions import Emitter

from stook.sdk import (
    ImageListMetric,
    MetricStatus,
    PlotlyMetric,
    ScalarMetric,
    TextMetric,
    read_job_metrics,
)
from stook.service.cli._main import run_cli

MP4 = b"\0\0\0\x18ftypmp42"

NAVIGATION = """\
version: 1
topics:
  camera_video:
    schema: {camera_name: string, filename: video}
  time_to_goal:
    schema: {time_s: float, goal_name: string}
metrics:
  Camera feed (bright scenes):
    type: batch
    query_string: |
      SELECT m.experience_name, cv.job_id
      FROM camera_video cv
      JOIN metadata m ON cv.job_id = m.job_id
      WHERE contains(m.custom_field_keys, 'Lighting')
        AND m.custom_field_values[array_position(m.custom_field_keys, 'Lighting')] = 'Bright'
      ORDER BY m.experience_name;
    template_type: system
    template: video
    skip_if_no_data: true
metrics sets:
  Nav:
    metrics: [Camera feed (bright scenes)]
"""

REPORT = """\
version: 1
topics: {}
metrics:
  Time by build:
    type: report
    query_string: |
      SELECT
        'Total time' AS group_name,
        date_format(MAX(m.build_creation_timestamp), '%Y-%m-%d') AS "Build date",
        SUM(t.time_s) AS "Time (s)"
      FROM time_to_goal t
      JOIN metadata m ON t.job_id = m.job_id
      WHERE m.build_creation_timestamp >= current_timestamp - interval '3' month
      GROUP BY m.batch_id
      ORDER BY MAX(m.build_creation_timestamp);
    template_type: system
    template: line
"""

DRONE = """\
version: 1
topics:
  flight_sample:
    schema: {speed: float, state: string, flight_status: string}
  flight_event:
    event: true
    schema: {name: string, description: string, status: status, tags: "string[]",
             metrics: "metric[]"}
metrics:
  Off-Nominal Samples:
    type: test
    query_string: |
      SELECT CAST(COUNT_IF(UPPER(flight_status) <> 'OK') AS DOUBLE) FROM flight_sample;
    status:
      query_string: |
        SELECT 1 FROM flight_sample
        WHERE CASE UPPER(flight_status) WHEN 'ERROR' THEN 2 WHEN 'WARNING' THEN 1 ELSE 0
              END >= ?
        HAVING COUNT(*) > 0;
      warn: 1
      block: 2
    template_type: system
    template: scalar
    units: samples
  States Observed:
    type: test
    query_string: |
      SELECT 'States' AS "Metric",
        ARRAY_JOIN(ARRAY_SORT(ARRAY_AGG(DISTINCT state)), ', ') AS "Value"
      FROM flight_sample;
    template_type: system
    template: table
  Health Path:
    type: test
    query_string: SELECT speed, UPPER(flight_status) AS health FROM flight_sample ORDER BY timestamp
    template_type: custom
    template_file: health.liquid
"""

HEALTH = """\
{"data": [{"y": [{% for v in speed %}{{ v }}{% unless forloop.last %},{% endunless %}{% endfor %}],
  "text": [{% for v in speed %}"{{ health[forloop.index0] }}"{% unless forloop.last %},{% endunless %}{% endfor %}],
  "marker": {"color": [{% for h in health %}"{% case h %}{% when 'WARNING' %}orange{% when 'ERROR' %}red{% else %}blue{% endcase %}"{% unless forloop.last %},{% endunless %}{% endfor %}]}}]}
"""  # noqa: E501 -- a template line as the demo writes it


def _write(folder: Path, name: str, text: str) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def _meta(k: int, lighting: str, built: dt.datetime) -> dict[str, Any]:
    return {
        "job_id": f"00000000-0000-4000-8000-00000000000{k}",
        "batch_id": f"00000000-0000-4000-8000-0000000000b{k}",
        "experience_name": f"scene-{k}",
        "custom_field_keys": ["Pedestrians", "Lighting"],
        "custom_field_values": ["No", lighting],
        "build_creation_timestamp": built.strftime("%Y-%m-%dT%H:%M:%SZ"),
    }


def _eval(argv: list[str], out: Path, capsys: pytest.CaptureFixture[str]) -> Any:
    code = run_cli(["metrics-config", "eval", *argv, "--outputs", str(out)])
    assert code == 0
    assert capsys.readouterr().err == ""  # no metric failed
    return read_job_metrics((out / "metrics.binproto").read_bytes())


def _navigation_jobs(tmp_path: Path, config: Path) -> tuple[Path, list[dt.datetime]]:
    now = dt.datetime.now(dt.UTC).replace(microsecond=0)
    # scene-3 was built five months ago: outside the report's three months.
    built = [now - dt.timedelta(days=d) for d in (20, 10, 5, 150)]
    lighting = ["Bright", "Dim", "Bright", "Bright"]
    jobs = tmp_path / "jobs"
    for k in range(4):
        folder = jobs / f"job-{k}"
        folder.mkdir(parents=True)
        # Every job attaches a file of the same name, as the demo's camera.mp4.
        (folder / "camera.mp4").write_bytes(MP4 + bytes([k]))
        with Emitter(config_path=config, output_path=folder / "emissions.resim.jsonl") as e:
            e.emit("camera_video", {"camera_name": "front", "filename": "camera.mp4"})
            for g in (1, 2):
                e.emit("time_to_goal", {"time_s": 10.0 * k + g, "goal_name": f"Goal {g}"})
        meta = _meta(k, lighting[k], built[k])
        (folder / "job.json").write_text(json.dumps(meta), encoding="utf-8")
    return jobs, built


def test_a_batch_video_by_job_shows_each_jobs_own_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = _write(tmp_path / "metrics", "config.resim.yml", NAVIGATION)
    jobs, _ = _navigation_jobs(tmp_path, config)
    out = tmp_path / "out"
    view = _eval([str(config), "--emissions", str(jobs), "--level", "batch"], out, capsys)
    feed = view.metric("Camera feed (bright scenes)", ImageListMetric)
    assert ("template", "video") in feed.view.tags
    bright = [f"00000000-0000-4000-8000-00000000000{k}" for k in (0, 2, 3)]
    assert [d.external_path for d in feed.image_data] == [f"{j}/camera.mp4" for j in bright]
    for k, job in zip((0, 2, 3), bright, strict=True):
        assert (out / job / "camera.mp4").read_bytes() == MP4 + bytes([k])  # its own file


def test_a_line_over_text_x_is_drawn_as_categories(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = _write(tmp_path / "metrics", "config.resim.yml", NAVIGATION)
    report = _write(tmp_path / "metrics", "report.resim.yml", REPORT)
    jobs, built = _navigation_jobs(tmp_path, config)
    code = run_cli(["metrics-config", "check", "--strict", str(config), str(report)])
    assert code == 0
    assert "type 'report' is read as 'dashboard'" in capsys.readouterr().err
    argv = [str(config), str(report), "--emissions", str(jobs), "--level", "dashboard"]
    code = run_cli(["metrics-config", "eval", *argv, "--outputs", str(tmp_path / "out")])
    assert code == 0
    err = capsys.readouterr().err
    assert "RENDER_ERROR" not in err
    view = read_job_metrics((tmp_path / "out" / "metrics.binproto").read_bytes())
    line = view.metric("Time by build", PlotlyMetric)
    assert ("template", "line") in line.view.tags
    (trace,) = line.json["data"]
    # One point per batch built within three months, oldest build first.
    assert trace["x"] == [built[k].strftime("%Y-%m-%d") for k in (0, 1, 2)]
    assert trace["y"] == [1.0 + 2.0, 11.0 + 12.0, 21.0 + 22.0]
    assert trace["name"] == "Total time"
    assert line.json["layout"]["xaxis"] == {"title": {"text": "Build date"}, "type": "category"}
    assert line.json["layout"]["yaxis"] == {"title": {"text": "Time (s)"}}


@pytest.mark.parametrize(
    ("health", "samples", "status"),
    [
        (["OK", "OK", "OK"], 0.0, MetricStatus.PASSED),
        (["OK", "WARNING", "OK"], 1.0, MetricStatus.FAIL_WARN),
        (["OK", "WARNING", "Error"], 2.0, MetricStatus.FAIL_BLOCK),
    ],
)
def test_the_drone_constructs_give_the_platforms_values(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    health: list[str],
    samples: float,
    status: MetricStatus,
) -> None:
    config = _write(tmp_path / "metrics", "config.resim.yml", DRONE)
    _write(tmp_path / "metrics" / "templates", "health.liquid", HEALTH)
    emissions = tmp_path / "job" / "emissions.resim.jsonl"
    emissions.parent.mkdir()
    states = ["takeoff", "cruise", "cruise"]
    with Emitter(config_path=config, output_path=emissions) as emitter:
        for i, (state, flag) in enumerate(zip(states, health, strict=True)):
            row = {"speed": 1.5 * i, "state": state, "flight_status": flag}
            emitter.emit("flight_sample", row, timestamp=i * 1_000_000_000)
        emitter.emit_event(
            "flight_event",
            {
                "name": "Lost link",
                "description": "no telemetry for 2 s",
                "status": "FAIL_BLOCK",
                "tags": ["link"],
                "metrics": [{"name": "gap", "type": "scalar", "value": 2.0, "unit": "s"}],
            },
            timestamp=1_500_000_000,
        )
    argv = [str(config), "--emissions", str(emissions), "--level", "test"]
    view = _eval(argv, tmp_path / "out", capsys)
    off = view.metric("Off-Nominal Samples", ScalarMetric)
    assert (off.value, off.unit, off.view.status) == (samples, "samples", status)
    table = view.metric("States Observed", TextMetric)
    assert "| States | cruise, takeoff |" in table.text
    (trace,) = view.metric("Health Path", PlotlyMetric).json["data"]
    assert trace["y"] == [0.0, 1.5, 3.0]
    assert trace["text"] == [h.upper() for h in health]
    colour = {"OK": "blue", "WARNING": "orange", "ERROR": "red"}
    assert trace["marker"]["color"] == [colour[h.upper()] for h in health]
    # The event's FAIL_BLOCK counts toward the test's result, whatever the metrics say.
    assert view.status == MetricStatus.FAIL_BLOCK
    (event,) = view.events
    assert (event.name, event.status, event.timestamp_ns) == (
        "Lost link",
        MetricStatus.FAIL_BLOCK,
        1_500_000_000,
    )
