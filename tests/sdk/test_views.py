"""The reader's views: frames of a whole output and of one data item."""

from __future__ import annotations

import uuid

import polars as pl
import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk import (
    JobMetricsView,
    MetricsWriter,
    SeriesKind,
    read_job_metrics,
)
from stook.sdk.dtypes import KIND_DTYPE, STATUS_DTYPE
from tests.sdk.resim_output import JOB_ID

# ---------------------------------------------------------------- a ReSim-written output


def test_per_category_frame(view: JobMetricsView) -> None:
    grouped = view.data_by_name["speeds by vehicle"]
    assert grouped.per_category
    assert grouped.categories == ("car", "bike")
    with pytest.raises(ValueError, match="per category"):
        grouped.series()
    frame = grouped.frame()
    assert dict(frame.schema) == (
        {"category": pl.String, "position": pl.UInt32, "value": pl.Float64}
    )
    assert frame.rows() == [("car", 0, 1.0), ("car", 1, -3.0), ("bike", 0, 2.5)]
    assert grouped.category_series("bike").to_list() == [2.5]
    with pytest.raises(KeyError):
        grouped.category_series("truck")
    assert grouped.index_id is not None
    assert view.data_by_id[grouped.index_id].name == "times by vehicle"


def test_plain_frame(view: JobMetricsView) -> None:
    frame = view.data_by_name["xs"].frame()
    assert frame.rows() == [(None, 0, 0.0), (None, 1, 1.0)]
    assert frame["category"].dtype == pl.String


def test_external_files_have_no_series(view: JobMetricsView) -> None:
    picture = view.data_by_name["picture"]
    assert picture.is_external
    assert picture.kind is SeriesKind.EXTERNAL_FILE
    assert picture.external_path == "images/a.png"
    with pytest.raises(ValueError, match="external file"):
        picture.series()
    with pytest.raises(ValueError, match="external file"):
        picture.frame()


def test_scalars_frame(view: JobMetricsView) -> None:
    frame = view.scalars_frame()
    assert dict(frame.schema) == (
        {
            "metric_id": pl.String,
            "name": pl.String,
            "value": pl.Float64,
            "unit": pl.String,
            "status": STATUS_DTYPE,
        }
    )
    assert frame.select("name", "value", "unit", "status").rows() == [
        ("Max speed", 2.5, "m/s", "PASSED"),
        ("Stop speed", 0.0, None, "PASSED"),
    ]


def test_series_frame(view: JobMetricsView) -> None:
    frame = view.series_frame()
    assert dict(frame.schema) == (
        {
            "data_id": pl.String,
            "data_name": pl.String,
            "kind": KIND_DTYPE,
            "category": pl.String,
            "position": pl.UInt32,
            "value_double": pl.Float64,
            "value_timestamp": pl.Datetime("ns", "UTC"),
            "value_uuid": pl.String,
            "value_string": pl.String,
            "value_status": STATUS_DTYPE,
        }
    )
    external = {d.name for d in view.data if d.is_external}
    assert external
    assert not external & set(frame["data_name"].to_list())
    assert len(frame) == sum(len(d.frame()) for d in view.data if not d.is_external)
    speeds = frame.filter(pl.col("data_name") == "speeds")
    assert speeds["value_double"].to_list() == [1.0, 2.5, -3.0]
    assert speeds["value_string"].null_count() == 3
    states = frame.filter(pl.col("kind") == "string", pl.col("data_name") == "states")
    assert states["value_string"].to_list() == ["idle", "drive", "idle"]


def test_empty_output_frames() -> None:
    job = pb.JobMetrics()
    job.job_id.id.data = str(JOB_ID)
    view = read_job_metrics(job.SerializeToString())
    assert view.series_frame().is_empty()
    assert view.scalars_frame().is_empty()
    assert view.series_frame().columns[0] == "data_id"
    assert view.metrics == ()
    assert view.data == ()
    assert view.events == ()


# ---------------------------------------------------------------- hand-made messages


def test_unknown_status_of_a_scalar_reads_as_null_in_the_frame() -> None:
    w = MetricsWriter(uuid.uuid4(), deterministic=True)
    w.scalar("x", 1.5)
    msg = w.to_proto()
    msg.job_level_metrics.metrics[0].status = 42  # type: ignore[assignment]
    view = read_job_metrics(msg.SerializeToString())
    assert view.metrics[0].status == 42
    assert view.scalars_frame()["status"].to_list() == [None]
