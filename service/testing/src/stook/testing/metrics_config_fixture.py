"""A realistic config.resim.yml (and its Liquid template) for tests of config-defined
metrics, written the way the platform's reference shows: an event topic, every system
template, a custom template, a status check, a skip_if_no_data metric, two metrics sets,
a dashboard. `write_fixture(folder)` lays it out as a repository does
(.resim/metrics/config.resim.yml, .resim/metrics/templates/*.liquid).
"""

from __future__ import annotations

from pathlib import Path

FIXTURE_CONFIG_YAML = """\
version: 1

topics:
  speed:
    schema:
      lane: string
      speed: float
  detections:
    schema:
      label: string
      count: int
      confident: boolean
  planner_state:
    schema:
      state: string
  camera:
    schema:
      frame: image
  lidar:
    schema:
      dropout_ms: float
  collision:
    event: true
    schema:
      name: string
      description: string
      status: status
      tags: string[]
      metrics: metric[]

metrics:
  Speed over time:
    type: test
    description: Speed per lane against time
    query_string: |
      SELECT lane AS "Lane", timestamp / 1E9 AS "Time (s)", speed AS "Speed (m/s)"
      FROM speed
      ORDER BY lane, timestamp
    template_type: system
    template: line

  Max speed:
    type: test
    description: The fastest the ego went
    query_string: SELECT MAX(speed) AS "Max speed" FROM speed
    template_type: system
    template: scalar
    units: m/s
    status:
      query_string: SELECT 1 FROM speed HAVING MAX(speed) > ?
      block: 30
      warn: 20

  Detections by label:
    type: test
    query_string: |
      SELECT CASE WHEN confident THEN 'confident' ELSE 'unsure' END AS "Confidence",
             label AS "Label", SUM(count) AS "Detections"
      FROM detections
      GROUP BY 1, 2
      ORDER BY 1, 2
    template_type: system
    template: bar

  Speed distribution:
    type: test
    query_string: SELECT speed AS "Speed (m/s)" FROM speed
    template_type: system
    template: histogram
    template_settings:
      display:
        bins: 10

  Planner states:
    type: test
    query_string: |
      SELECT 'planner' AS system, timestamp, state FROM planner_state ORDER BY timestamp
    template_type: system
    template: state_timeline

  Detection share:
    type: test
    query_string: |
      SELECT label, SUM(count) AS detections FROM detections GROUP BY label ORDER BY label
    template_type: system
    template: pie

  Speed summary:
    type: test
    query_string: |
      SELECT lane AS "Lane", COUNT(*) AS "Samples", ROUND(AVG(speed), 3) AS "Mean speed",
             CAST(MAX(speed) AS VARCHAR) || ' m/s' AS "Top speed"
      FROM speed
      GROUP BY lane
      ORDER BY lane
    template_type: system
    template: table

  Camera frame:
    type: test
    query_string: SELECT ARBITRARY(frame) AS frame FROM camera
    template_type: system
    template: image

  Speed figure:
    type: test
    query_string: |
      SELECT timestamp / 1E9 AS t, speed AS v, lane FROM speed ORDER BY lane, timestamp
    template_type: custom
    template_file: speed_figure.liquid

  Lidar dropouts:
    type: test
    description: Hidden when the lidar emitted nothing
    query_string: SELECT dropout_ms FROM lidar
    template_type: system
    template: histogram
    skip_if_no_data: true

  Worst lidar dropout:
    type: test
    description: NO_DATA when the lidar emitted nothing; its status does not run then
    query_string: SELECT MAX(dropout_ms) FROM lidar
    template_type: system
    template: scalar
    units: ms
    status:
      query_string: SELECT 1 FROM lidar HAVING COUNT(*) < ?
      block: 1

  Lidar samples:
    type: test
    description: COUNT(*) always has a row, so its status blocks on absence
    query_string: SELECT COUNT(*) AS "Samples" FROM lidar
    template_type: system
    template: scalar
    status:
      query_string: SELECT 1 FROM lidar HAVING COUNT(*) < ?
      block: 1

  Max speed per experience:
    type: batch
    query_string: |
      WITH per_job AS (
        SELECT job_id, MAX(speed) AS top FROM speed GROUP BY job_id
      )
      SELECT m.experience_name AS "Experience", p.top AS "Max speed"
      FROM per_job p JOIN metadata m ON p.job_id = m.job_id
      ORDER BY 1
    template_type: system
    template: bar

  Jobs over the limit:
    type: batch
    query_string: |
      SELECT COUNT_IF(top > 25) AS "Jobs" FROM (
        SELECT job_id, MAX(speed) AS top FROM speed GROUP BY job_id
      )
    template_type: system
    template: scalar
    status:
      query_string: |
        SELECT 1 FROM (SELECT job_id, MAX(speed) AS top FROM speed GROUP BY job_id)
        HAVING COUNT_IF(top > 25) >= ?
      block: 2
      warn: 1

  Largest speed jump:
    type: batch
    query_string: |
      WITH steps AS (
        SELECT speed - LAG(speed) OVER (PARTITION BY job_id, lane ORDER BY timestamp) AS jump
        FROM speed
      )
      SELECT MAX(jump) FROM steps
    template_type: system
    template: scalar
    units: m/s

  Median speed:
    type: batch
    query_string: SELECT APPROX_PERCENTILE(speed, 0.5) FROM speed
    template_type: system
    template: scalar

  Job outcomes:
    type: batch
    query_string: |
      SELECT CONCAT('status ', COALESCE(job_conflated_status, 'unknown')) AS "Outcome",
             COUNT(*) AS "Jobs"
      FROM metadata GROUP BY 1
      UNION ALL
      SELECT 'all', COUNT(*) FROM metadata
      ORDER BY 1
    template_type: system
    template: table

  Collisions:
    type: batch
    query_string: SELECT COUNT(*) AS "Collisions" FROM collision
    template_type: system
    template: scalar
    status:
      query_string: SELECT 1 FROM collision HAVING COUNT(*) >= ?
      warn: 1

  Max speed by version:
    type: dashboard
    query_string: |
      SELECT build_version AS "Version", MAX(speed) AS "Max speed"
      FROM speed GROUP BY build_version ORDER BY build_version
    template_type: system
    template: bar

metrics sets:
  core:
    metrics: [Max speed, Speed over time, Detections by label, Worst lidar dropout]
  overview:
    metrics: [Max speed per experience, Jobs over the limit, Max speed by version]

dashboards:
  Speed:
    metrics_set: overview
    refresh: auto
    day_range: 90
"""

SPEED_FIGURE_LIQUID = """\
{%- assign lanes = lane | uniq -%}
{"data": [
{%- for name in lanes -%}
  {%- unless forloop.first %},{% endunless -%}
  {"type": "scatter", "mode": "lines", "name": {{ name | json }}, "x": [
  {%- assign first = true -%}
  {%- for value in t -%}
    {%- if lane[forloop.index0] == name -%}
      {%- unless first %},{% endunless -%}{{ value | json }}{%- assign first = false -%}
    {%- endif -%}
  {%- endfor -%}
  ], "y": [
  {%- assign first = true -%}
  {%- for value in v -%}
    {%- if lane[forloop.index0] == name -%}
      {%- unless first %},{% endunless -%}{{ value | json }}{%- assign first = false -%}
    {%- endif -%}
  {%- endfor -%}
  ]}
{%- endfor -%}
], "layout": {"title": {"text": "Speed"}}}
"""

FIXTURE_TEMPLATES = {"speed_figure.liquid": SPEED_FIGURE_LIQUID}


def write_fixture(folder: Path) -> Path:
    """Lay the config out in `folder` as a repository does; the config file's path."""
    metrics = folder / ".resim" / "metrics"
    (metrics / "templates").mkdir(parents=True, exist_ok=True)
    config = metrics / "config.resim.yml"
    config.write_text(FIXTURE_CONFIG_YAML, encoding="utf-8")
    for name, text in FIXTURE_TEMPLATES.items():
        (metrics / "templates" / name).write_text(text, encoding="utf-8")
    return config
