"""The shorter column forms real configs use (read by position and count), and values
the engine returns in other types (decimals, floats for times, NULLs)."""

from __future__ import annotations

import decimal
import json
import uuid
from pathlib import Path

from stook.sdk import (
    BarChartMetric,
    HistogramMetric,
    LinePlotMetric,
    MetricsWriter,
    ScalarMetric,
    StatesOverTimeMetric,
    TextMetric,
    read_job_metrics,
    validate_job_metrics,
)
from stook.service.metrics_config import EmissionsSet, JobMeta, evaluate, load_config

CONFIG = """\
version: 1
topics:
  points:
    schema: {g: string, v: float}
metrics:
  Two-column line:
    type: batch
    query_string: SELECT v AS "X", v * 2 AS "Double" FROM points ORDER BY v
    template: line
  Two-column bar:
    type: batch
    query_string: SELECT g, SUM(v) FROM points GROUP BY g ORDER BY g
    template: bar
  Grouped histogram:
    type: batch
    query_string: SELECT g, v FROM points ORDER BY g
    template: histogram
  Decimal scalar:
    type: batch
    query_string: SELECT CAST(SUM(v) AS DECIMAL(10, 2)) FROM points
    template: scalar
  Seconds timeline:
    type: batch
    query_string: |
      SELECT g, v / 10.0, CASE WHEN v > 2 THEN 'high' ELSE 'low' END
      FROM points ORDER BY g, v
    template: state_timeline
  Nulls in a table:
    type: batch
    query_string: SELECT g, NULL AS "nothing", ARRAY['a', 'b'] AS l FROM points WHERE v = 1
    template: table
"""

POINTS = [("a", 1.0), ("a", 2.0), ("b", 3.0), ("b", 5.0), ("b", 8.0)]


def _output(tmp_path: Path) -> bytes:
    (tmp_path / "c.yml").write_text(CONFIG, encoding="utf-8")
    config = load_config([tmp_path / "c.yml"])
    emissions = EmissionsSet(config)
    lines = [
        json.dumps({"$metadata": {"topic": "points"}, "$data": {"g": g, "v": v}}) for g, v in POINTS
    ]
    emissions.add_job(JobMeta(job_id="j"), "\n".join(lines).encode())
    writer = MetricsWriter(uuid.UUID(int=7), deterministic=True)
    evaluate(config, emissions.tables(), writer, level="batch")
    return writer.serialize()


def test_short_forms_and_value_types(tmp_path: Path) -> None:
    view = read_job_metrics(_output(tmp_path))
    validate_job_metrics(view.raw)
    values = sorted(v for _, v in POINTS)

    line = view.metric("Two-column line", LinePlotMetric)
    assert line.legend == ("Double",)  # the one series is named by the y alias
    assert list(line.x_doubles_data[0].values()) == values
    assert list(line.y_doubles_data[0].values()) == [2 * v for v in values]

    bar = view.metric("Two-column bar", BarChartMetric)
    sums: dict[str, float] = {}
    for g, v in POINTS:
        sums[g] = sums.get(g, 0.0) + v
    assert dict(bar.values_data[0].labelled()) == sums

    # One histogram under the configured name: its values indexed by their groups.
    hist = view.metric("Grouped histogram", HistogramMetric)
    assert hist.values_data is not None
    assert hist.values_data.labelled() == tuple(POINTS)
    assert len(hist.buckets) == 20  # the default
    assert not any(m.name.startswith("Grouped histogram (") for m in view.metrics)

    total = sum(decimal.Decimal(str(v)) for _, v in POINTS)
    assert view.metric("Decimal scalar", ScalarMetric).value == float(total)

    timeline = view.metric("Seconds timeline", StatesOverTimeMetric)
    assert timeline.legend == ("a", "b")
    b_states = timeline.states_over_time_data[1].labelled()
    assert b_states == tuple(
        (round(v / 10 * 1e9), "high" if v > 2 else "low") for g, v in POINTS if g == "b"
    )

    table = view.metric("Nulls in a table", TextMetric).text.splitlines()
    assert table == ["| g | nothing | l |", "|---|---|---|", '| a |  | ["a", "b"] |']


def test_the_same_inputs_give_the_same_bytes(tmp_path: Path) -> None:
    (tmp_path / "one").mkdir()
    (tmp_path / "two").mkdir()
    assert _output(tmp_path / "one") == _output(tmp_path / "two")
