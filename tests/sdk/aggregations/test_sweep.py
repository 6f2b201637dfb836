"""[[batch.sweep]]: each metric's mean per parameter value, as a Markdown table and lines."""

from __future__ import annotations

import math
import uuid

import pytest

from stook.sdk import MetricStatus, MetricType
from stook.sdk.aggregations import Needs, ParameterSweep, Scalar
from tests.sdk.aggregations.job_outputs import job_with
from tests.sdk.aggregations.support import Output, fold


def run(params: dict[str, str], **scalars: float | Scalar):  # type: ignore[no-untyped-def]
    return job_with(parameters=params, scalars=scalars)


def line(out: Output, name: str) -> tuple[list[float], list[float]]:
    m = out.metric(name, MetricType.LINE_PLOT)
    lv = m.raw.metric_values.line_plot_metric_values
    (x,), (y,) = lv.x_doubles_data_id, lv.y_doubles_data_id
    return (
        out.view.data_by_id[uuid.UUID(x.id.data)].series().to_list(),
        out.view.data_by_id[uuid.UUID(y.id.data)].series().to_list(),
    )


def text(out: Output, name: str) -> str:
    return out.metric(name, MetricType.TEXT).raw.metric_values.text_metric_values.text


def test_one_parameter_gives_a_table_and_a_line_per_metric() -> None:
    jobs = [
        run({"max_speed": "10"}, Collisions=Scalar(1.0, "count"), Time=4.0),
        run({"max_speed": "10"}, Collisions=Scalar(3.0, "count")),
        run({"max_speed": "2.5"}, Collisions=0.0, Time=8.0),
        run({"max_speed": "30"}, Collisions=5.0, Time=math.nan),
        run({}, Collisions=7.0),
    ]
    agg = ParameterSweep(parameters=["max_speed"], metrics=["Collisions", "Time"])
    out = Output(fold(agg, jobs))
    assert out.names == [
        "Parameter sweep",
        "Parameter sweep: Collisions by max_speed",
        "Parameter sweep: Time by max_speed",
    ]
    # Numeric values sort as numbers (2.5 before 10); unset last; no value: a dash.
    assert text(out, "Parameter sweep") == (
        "Means per value of max_speed over 5 jobs.\n\n"
        "| max_speed | jobs | Collisions (mean, count) | Time (mean) |\n"
        "|---|---|---|---|\n"
        "| 2.5 | 1 | 0 | 8 |\n"
        "| 10 | 2 | 2 | 4 |\n"
        "| 30 | 1 | 5 | – |\n"
        "| (unset) | 1 | 7 | – |\n"
    )
    assert line(out, "Parameter sweep: Collisions by max_speed") == ([2.5, 10.0, 30.0], [0, 2, 5])
    assert line(out, "Parameter sweep: Time by max_speed") == ([2.5, 10.0], [8.0, 4.0])


def test_two_parameters_give_rows_per_combination_and_lines_per_parameter() -> None:
    jobs = [
        run({"max_speed": "10", "map": "city"}, C=1.0),
        run({"max_speed": "10", "map": "highway"}, C=3.0),
        run({"max_speed": "20", "map": "city"}, C=5.0),
        run({"max_speed": "10.0", "map": "city"}, C=7.0),
    ]
    out = Output(fold(ParameterSweep(parameters=["max_speed", "map"], metrics=["C"]), jobs))
    rows = text(out, "Parameter sweep").splitlines()[4:]
    assert rows == [
        "| 10 | city | 1 | 1 |",
        "| 10 | highway | 1 | 3 |",
        "| 10.0 | city | 1 | 7 |",
        "| 20 | city | 1 | 5 |",
    ]
    # "10" and "10.0" are one point; its mean pools their jobs.
    assert line(out, "Parameter sweep: C by max_speed") == ([10.0, 20.0], [11 / 3, 5.0])
    # A parameter whose values are not numbers gets a bar per value instead of a line.
    bars = out.bars("Parameter sweep: C by map")
    assert bars == {"city": 13 / 3, "highway": 3.0}


def test_table_cells_cannot_break_the_table() -> None:
    out = Output(fold(ParameterSweep(parameters=["p"], metrics=["C"]), [run({"p": "a|b\nc"}, C=1)]))
    assert "| a\\|b c | 1 | 1 |" in text(out, "Parameter sweep")


def test_no_jobs_say_so() -> None:
    out = Output(ParameterSweep(parameters=["p"], metrics=["C"]))
    assert out.metric("Parameter sweep", MetricType.TEXT).status is MetricStatus.NOT_APPLICABLE


def test_needs_are_the_scalars() -> None:
    agg = ParameterSweep(parameters=["p"], metrics=["A", "B"])
    assert agg.needs() == Needs(scalars=frozenset({"A", "B"}))


@pytest.mark.parametrize(
    ("parameters", "metrics", "message"),
    [([], ["A"], "'parameters' must name at least one"), (["p"], ["A", "A"], "names one twice")],
)
def test_bad_lists_are_refused(parameters: list[str], metrics: list[str], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        ParameterSweep(parameters=parameters, metrics=metrics)
