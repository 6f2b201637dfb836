"""Templates as the platform renders them: a text scalar shown as text, groups inside
one metric under its configured name, `template_settings` where JobMetrics holds it and
as a tag, a bar's link_path, video and artifact metrics."""

from __future__ import annotations

import json
import uuid
from pathlib import Path

from stook.sdk import (
    BarChartMetric,
    HistogramMetric,
    ImageListMetric,
    JobMetricsView,
    LinePlotMetric,
    MetricStatus,
    MetricsWriter,
    PlotlyMetric,
    TextMetric,
    read_job_metrics,
    validate_job_metrics,
)
from stook.service.metrics_config import EmissionsSet, JobMeta, evaluate, load_config

CONFIG = """\
version: 1
topics:
  run:
    schema: {seconds: float, clip: video, log: string}
  points:
    schema: {g: string, v: float}
metrics:
  Duration:
    type: test
    query_string: |
      SELECT LPAD(CAST(CAST(FLOOR(seconds / 3600) AS INTEGER) AS VARCHAR), 2, '0') || ':' ||
             LPAD(CAST(CAST(FLOOR(MOD(seconds, 3600) / 60) AS INTEGER) AS VARCHAR), 2, '0') ||
             ':' || LPAD(CAST(CAST(FLOOR(MOD(seconds, 60)) AS INTEGER) AS VARCHAR), 2, '0')
             AS value
      FROM run
    template: scalar
    status: {query_string: "SELECT 1 FROM run WHERE seconds > ?", warn: 5}
  Distance:
    type: test
    query_string: SELECT 'far' AS value
    template: scalar
    units: km
  Spread:
    type: test
    query_string: SELECT 'Values' AS group_name, v AS "V" FROM points
    template: histogram
    template_settings: {xaxis: {label: Value (m), min: 0, max: 10}, display: {bins: 5}}
  By group:
    type: test
    query_string: SELECT g AS group_name, v AS x, 2 * v AS y FROM points ORDER BY 1, 2
    template: line
    template_settings:
      xaxis: {label: Time}
      yaxis: {label: Height, min: 0}
      series: [{group_name: b, color: "#AE84DE"}]
      display: {legend: bottom}
  Totals:
    type: test
    query_string: |
      SELECT 'sum' AS group_name, g AS "Group", SUM(v) AS "Total",
             CASE WHEN g = 'a' THEN '/runs/a' END AS link_path
      FROM points GROUP BY g ORDER BY g
    template: bar
  Shares:
    type: test
    query_string: SELECT g, SUM(v) FROM points GROUP BY g ORDER BY g
    template: pie
    template_settings:
      display: {text_info: label_percent, legend: false}
      series: [{group_name: a, color: "#D3FAA3"}]
  Clip:
    type: test
    query_string: SELECT clip FROM run
    template: video
  Logs:
    type: test
    query_string: SELECT log FROM run
    template: artifact
"""

POINTS = [("a", 1.0), ("a", 2.0), ("b", 3.0), ("b", 12.0)]


def _evaluate(tmp_path: Path) -> tuple[bytes, JobMetricsView]:
    (tmp_path / "c.yml").write_text(CONFIG, encoding="utf-8")
    config = load_config([tmp_path / "c.yml"])
    lines = [{"$metadata": {"topic": "points"}, "$data": {"g": g, "v": v}} for g, v in POINTS]
    lines += [
        {"$metadata": {"topic": "run"}, "$data": {"seconds": s, "clip": c, "log": f"{c}.log"}}
        for s, c in ((7.9, "one.mp4"), (3661.0, "two.mp4"))
    ]
    emissions = EmissionsSet(config)
    emissions.add_job(JobMeta(job_id="j"), "\n".join(json.dumps(x) for x in lines).encode())
    writer = MetricsWriter(uuid.UUID(int=3), deterministic=True)
    done = evaluate(config, emissions.tables(), writer, level="test", attached=lambda n: True)
    assert done.failed == []
    assert done.files == ["one.mp4", "two.mp4", "one.mp4.log", "two.mp4.log"]
    raw = writer.serialize()
    view = read_job_metrics(raw)
    validate_job_metrics(view.raw)
    return raw, view


def _tags(view: JobMetricsView, name: str) -> dict[str, str]:
    found = view.find_metric(name)
    assert found is not None
    return dict(found.tags)


def test_a_scalar_of_text_is_shown_as_its_text(tmp_path: Path) -> None:
    _, view = _evaluate(tmp_path)
    duration = view.metric("Duration", TextMetric)
    assert duration.text == "00:00:07"  # the first row's; FLOOR, not rounding
    assert duration.status is MetricStatus.FAIL_WARN  # its status query still runs
    assert _tags(view, "Duration") == {"template": "scalar"}
    assert view.metric("Distance", TextMetric).text == "far km"


def test_groups_stay_inside_the_metric_and_settings_reach_it(tmp_path: Path) -> None:
    _, view = _evaluate(tmp_path)
    spread = view.metric("Spread", HistogramMetric)
    assert not [m.name for m in view.metrics if m.name.startswith("Spread (")]
    assert spread.values_data is not None
    assert spread.values_data.labelled() == tuple(("Values", v) for _, v in POINTS)
    assert spread.x_axis_name == "Value (m)"
    assert [(b.lower, b.upper) for b in spread.buckets] == [
        (2.0 * i, 2.0 * i + 2) for i in range(5)
    ]

    line = view.metric("By group", LinePlotMetric)
    assert line.legend == ("a", "b")
    assert (line.x_axis_name, line.y_axis_name) == ("Time", "Height")
    settings = json.loads(_tags(view, "By group")["template_settings"])
    assert settings["series"] == [{"group_name": "b", "color": "#AE84DE"}]
    assert settings["yaxis"] == {"label": "Height", "min": 0}
    assert settings["display"] == {"legend": "bottom"}

    (pie,) = view.metric("Shares", PlotlyMetric).json["data"]
    assert pie["textinfo"] == "label+percent"
    assert pie["marker"] == {"colors": ["#D3FAA3", None]}
    assert view.metric("Shares", PlotlyMetric).json["layout"]["showlegend"] is False


def test_a_bars_link_path_is_kept(tmp_path: Path) -> None:
    _, view = _evaluate(tmp_path)
    bar = view.metric("Totals", BarChartMetric)
    assert dict(bar.values_data[0].labelled()) == {"a": 3.0, "b": 15.0}
    assert json.loads(_tags(view, "Totals")["link_paths"]) == {"sum": {"a": "/runs/a"}}
    assert "template_settings" not in _tags(view, "Totals")


def test_video_and_artifact_are_tagged_external_files(tmp_path: Path) -> None:
    _, view = _evaluate(tmp_path)
    clips = view.metric("Clip", ImageListMetric)
    assert [d.external_path for d in clips.image_data] == ["one.mp4", "two.mp4"]
    assert _tags(view, "Clip") == {"template": "video"}
    assert _tags(view, "Logs") == {"template": "artifact"}


def test_the_same_inputs_give_the_same_bytes(tmp_path: Path) -> None:
    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    assert _evaluate(tmp_path / "one")[0] == _evaluate(tmp_path / "two")[0]
