"""The SDK reader: bytes -> typed views, what it reads, and what it refuses."""

from __future__ import annotations

import contextlib
import uuid

import pytest
from hypothesis import given
from hypothesis import strategies as st
from resim.metrics.proto import metrics_pb2 as resim_pb
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.proto import metrics_pb2 as pb
from stook.sdk import (
    JobMetricsView,
    MetricsDataView,
    MetricType,
    ReadError,
    find_problems,
    parse_job_metrics,
    parse_metric,
    parse_metrics_data,
    read_job_metrics,
    read_metric,
    read_metrics_data,
)
from stook.sdk import MetricStatus as StookStatus
from tests.hypothesis_profiles import examples
from tests.sdk.resim_output import JOB_ID
from tests.sdk.support import bare_data
from tests.strategies import valid_job_metrics

# ---------------------------------------------------------------- a ReSim-written output


def test_resim_output_is_valid_for_both_validators(resim_msg: resim_pb.JobMetrics) -> None:
    resim_validate(resim_msg)
    assert find_problems(pb.JobMetrics.FromString(resim_msg.SerializeToString())) == []


def test_resim_output_is_read_with_nothing_lost(
    resim_msg: resim_pb.JobMetrics, view: JobMetricsView
) -> None:
    wire = resim_msg.SerializeToString(deterministic=True)
    assert view.raw.SerializeToString(deterministic=True) == wire
    for metric, theirs in zip(view.metrics, resim_msg.job_level_metrics.metrics, strict=True):
        assert metric.raw.SerializeToString() == theirs.SerializeToString()
        single = read_metric(theirs.SerializeToString())
        assert single == metric
    for data, theirs_data in zip(view.data, resim_msg.metrics_data, strict=True):
        wire_data = theirs_data.SerializeToString(deterministic=True)
        assert read_metrics_data(wire_data).raw.SerializeToString(deterministic=True) == wire_data
        assert data.raw.SerializeToString(deterministic=True) == wire_data


def test_every_metric_type_is_read(view: JobMetricsView) -> None:
    assert {m.type for m in view.metrics} == set(MetricType)
    assert view.job_id == JOB_ID
    assert view.status is StookStatus.PASSED
    for metric in view.metrics:
        assert metric.job_id == JOB_ID
        assert metric.status is StookStatus.PASSED
        assert metric.description == "described"
        assert metric.should_display is True
        assert metric.blocking is False
        assert metric.order is not None


def test_metric_fields(view: JobMetricsView) -> None:
    by_name = {m.name: m for m in view.metrics}
    scalar = by_name["Max speed"]
    assert (scalar.value, scalar.unit, scalar.tags) == (2.5, "m/s", (("team", "planning"),))
    assert scalar.data_ids == ()
    assert scalar.event_metric is False
    assert by_name["Stop speed"].event_metric is True
    assert by_name["Speed"].value is None
    assert by_name["Speed"].unit is None
    # Every referenced data, whatever the field, exists in the output.
    for metric in view.metrics:
        for data_id in metric.data_ids:
            assert data_id in view.data_by_id
    names = {m.name: {view.data_by_id[i].name for i in m.data_ids} for m in view.metrics}
    assert names["Speed"] == {"speeds", "speed statuses"}
    assert names["Path"] == {"xs", "ys", "xy statuses"}
    assert names["Batches"] == {"batch values", "batch times", "batch statuses"}
    assert names["Histogram"] == names["Summary"] == {"hist values", "hist statuses"}
    assert names["Image"] == {"picture"}
    assert names["Images"] == {"picture 0", "picture 1"}
    assert names["Text"] == names["Plot"] == set()


def test_events(view: JobMetricsView) -> None:
    (event,) = view.events
    assert event.name == "Stop"
    assert event.timestamp_ns == 7_000_000_009
    assert event.timestamp_type == "absolute"
    assert event.tags == ("stops",)
    assert [view.metrics_by_id[i].name for i in event.metric_ids] == ["Stop speed"]
    assert event.status is StookStatus.PASSED


# ---------------------------------------------------------------- hand-made messages


def test_unset_optional_fields_read_as_none() -> None:
    m = pb.Metric(name="bare")
    m.metric_id.id.data = str(uuid.uuid4())
    view = read_metric(m.SerializeToString())
    for name in ("type", "status", "importance", "job_id", "order", "blocking", "should_display"):
        assert getattr(view, name) is None, name
    assert view.value is None
    assert view.data_ids == ()
    scalar = pb.Metric(name="s", type=pb.SCALAR_METRIC_TYPE)
    scalar.metric_id.id.data = str(uuid.uuid4())
    scalar.metric_values.scalar_metric_values.SetInParent()
    assert parse_metric(scalar).value is None


def test_parse_variants_copy_the_message() -> None:
    d = bare_data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.doubles.series.append(1.0)
    view = parse_metrics_data(d)
    d.series.doubles.series.append(2.0)
    assert view.series().to_list() == [1.0]
    job = pb.JobMetrics()
    job.metrics_data.append(d)
    assert len(parse_job_metrics(job).data) == 1


# ---------------------------------------------------------------- refusals


@pytest.mark.parametrize("reader", [read_job_metrics, read_metric, read_metrics_data])
def test_empty_bytes_are_refused(reader: object) -> None:
    with pytest.raises(ReadError, match=r"from 'empty.bin': no bytes"):
        reader(b"", source="empty.bin")  # type: ignore[operator]


def _top_level_boundaries(msg: pb.JobMetrics) -> set[int]:
    """Offsets at which a cut leaves a shorter but well-formed JobMetrics."""
    boundaries, partial = {0}, pb.JobMetrics()
    for fd, value in msg.ListFields():
        for item in list(value) if fd.is_repeated else [value]:
            if fd.is_repeated:
                getattr(partial, fd.name).append(item)
            elif fd.message_type is not None:
                getattr(partial, fd.name).CopyFrom(item)
            else:
                setattr(partial, fd.name, item)
            boundaries.add(len(partial.SerializeToString(deterministic=True)))
    return boundaries


def test_truncated_bytes_are_refused_at_every_cut(resim_msg: resim_pb.JobMetrics) -> None:
    # Deterministic on both sides: map entries (per-category series) may otherwise come out
    # in a different order, which made this comparison flaky.
    wire = resim_msg.SerializeToString(deterministic=True)
    ours = pb.JobMetrics.FromString(wire)
    boundaries = _top_level_boundaries(ours)
    assert wire == ours.SerializeToString(deterministic=True)
    refused = 0
    for cut in range(len(wire)):
        if cut in boundaries and cut:
            read_job_metrics(wire[:cut])  # a well-formed prefix: protobuf cannot tell
            continue
        with pytest.raises(ReadError) as info:
            read_job_metrics(wire[:cut], source="cut.bin")
        assert str(info.value).startswith("could not read JobMetrics from 'cut.bin': ")
        assert "\n" not in str(info.value)
        refused += 1
    assert refused > len(wire) * 0.9


def test_truncation_error_is_chained_from_protobuf(resim_msg: resim_pb.JobMetrics) -> None:
    wire = resim_msg.SerializeToString()
    with pytest.raises(ReadError, match="not a valid protobuf message") as info:
        read_job_metrics(wire[: len(wire) // 2], source="half.bin")
    assert type(info.value.__cause__).__name__ == "DecodeError"


def test_another_message_type_is_refused(resim_msg: resim_pb.JobMetrics) -> None:
    metric = resim_msg.job_level_metrics.metrics[0].SerializeToString()
    with pytest.raises(ReadError, match=r"could not read MetricsData from 'm.bin': "):
        read_metrics_data(metric, source="m.bin")
    # Parses, but Metric's name (2) and type (3) have the wrong wire types for
    # MetricsData's data_type (2) and name (3): protobuf keeps them as unknown fields.
    small = pb.Metric(name="x", type=pb.SCALAR_METRIC_TYPE).SerializeToString()
    with pytest.raises(ReadError, match=r"field number\(s\) 2, 3 do not fit MetricsData"):
        read_metrics_data(small, source="m.bin")
    data = resim_msg.metrics_data[0].SerializeToString()
    with pytest.raises(ReadError, match="could not read Metric from"):
        read_metric(data)
    with pytest.raises(ReadError, match="could not read JobMetrics from"):
        read_job_metrics(metric)


def test_unknown_enum_values_are_read_and_kept() -> None:
    """A newer schema's enum values (ReSim's validator accepts them) are read, not refused."""
    m = pb.Metric(name="odd", type=99, status=42, importance=9)  # type: ignore[arg-type]
    m.metric_id.id.data = str(uuid.uuid4())
    metric = read_metric(m.SerializeToString(), source="odd.bin")
    assert (metric.type, metric.status, metric.importance) == (99, 42, 9)
    assert not isinstance(metric.status, StookStatus)  # the number, not a member

    d = bare_data(77)
    d.series.doubles.series.append(1.0)
    unknown = read_metrics_data(d.SerializeToString())
    assert unknown.kind is None
    assert unknown.raw.data_type == 77
    with pytest.raises(ValueError, match="data type 77, which this schema does not know"):
        unknown.frame()

    s = bare_data(pb.METRIC_STATUS_SERIES_DATA_TYPE)
    s.series.statuses.series.extend(pb.MetricStatus.ValueType(v) for v in (1, 40))
    statuses = read_metrics_data(s.SerializeToString())
    assert statuses.series().to_list() == ["PASSED", None]  # frames hold known names only
    assert list(statuses.raw.series.statuses.series) == [1, 40]

    e = pb.Event(name="e", status=43, timestamp_type=7)  # type: ignore[arg-type]
    e.event_id.id.data = str(uuid.uuid4())
    job = pb.JobMetrics(metrics_status=44)  # type: ignore[arg-type]
    job.job_id.id.data = str(uuid.uuid4())
    job.job_level_metrics.metrics.append(m)
    job.metrics_data.extend([d, s])
    job.events.append(e)
    view = read_job_metrics(job.SerializeToString())
    assert view.status == 44
    assert (view.events[0].status, view.events[0].timestamp_type) == (43, 7)
    assert view.scalars_frame().height == 0  # type 99 is not SCALAR
    # The unknown data type has no series to put in the frame; the statuses have.
    assert view.series_frame()["data_name"].to_list() == ["d", "d"]


def test_series_of_the_wrong_kind_is_refused() -> None:
    d = bare_data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.series.strings.series.append("x")
    with pytest.raises(ReadError, match="declared double but its series holds strings"):
        read_metrics_data(d.SerializeToString())


def test_missing_or_bad_ids_are_refused() -> None:
    m = pb.Metric(name="no id")
    with pytest.raises(ReadError, match="metric 'no id': id is missing"):
        read_metric(m.SerializeToString())
    m.metric_id.id.data = "xyz"
    with pytest.raises(ReadError, match="metric 'no id': id 'xyz' is not a UUID"):
        read_metric(m.SerializeToString())


def _refused_data() -> list[tuple[pb.MetricsData, str]]:
    def data(kind: int, name: str = "d", **fields: object) -> pb.MetricsData:
        d = bare_data(kind, **fields)
        d.name = name
        return d

    cases = [
        (data(pb.NO_DATA_TYPE), "data 'd': data type is unset"),
        (data(pb.NO_DATA_TYPE, name=""), "data (unnamed): data type is unset"),
    ]
    d = data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.metrics_data_id.id.data = ""
    cases.append((d, "data 'd': id is missing"))
    d = data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.metrics_data_id.id.data = "{418e78d2-c5d6-576c-af09-0f8c761e8ee}"
    cases.append((d, "data 'd': id '{418e78d2-c5d6-576c-af09-0f8c761e8ee}' is not a UUID"))
    d = data(pb.DOUBLE_SERIES_DATA_TYPE)
    d.index_data_id.id.data = "zz"
    cases.append((d, "data 'd': index id 'zz' is not a UUID"))
    d = data(pb.EXTERNAL_FILE_DATA_TYPE)
    d.series.doubles.series.append(1.0)
    cases.append((d, "data 'd' is declared an external file but holds a series"))
    d = data(pb.DOUBLE_SERIES_DATA_TYPE, is_per_category=True)
    d.series.doubles.series.append(1.0)
    cases.append((d, "data 'd': is_per_category is True but it holds series"))
    d = data(pb.DOUBLE_SERIES_DATA_TYPE, name="")
    d.series.strings.series.append("x")
    cases.append((d, "data (unnamed) is declared double but its series holds strings"))
    d = data(pb.DOUBLE_SERIES_DATA_TYPE, is_per_category=True)
    d.series_per_category.category_to_series["a"].strings.series.append("x")
    cases.append((d, "data 'd' is declared double but its series holds strings"))
    return cases


@pytest.mark.parametrize(("msg", "error"), _refused_data())
def test_refused_data_is_named_in_the_error(msg: pb.MetricsData, error: str) -> None:
    # The label is made only for an error (see `_data_view`); it must still say this.
    with pytest.raises(ReadError) as info:
        read_metrics_data(msg.SerializeToString(), source="s.bin")
    assert str(info.value) == f"could not read MetricsData from 's.bin': {error}"


# ---------------------------------------------------------------- fuzzing


_FUZZ = examples(300)


def _read_everything(data: bytes) -> None:
    """Read data as each message type; only ReadError may escape."""
    views: list[object] = []
    for reader in (read_job_metrics, read_metric, read_metrics_data):
        try:
            views.append(reader(data, source="fuzz"))
        except ReadError as exc:
            message = str(exc)
            assert message.startswith("could not read ")
            assert "from 'fuzz': " in message
    for view in views:
        if isinstance(view, JobMetricsView):
            datas = list(view.data)
        elif isinstance(view, MetricsDataView):
            datas = [view]
        else:
            datas = []
        for d in datas:
            if d.is_external or d.kind is None:
                continue
            with contextlib.suppress(ReadError):  # e.g. a bad UUID inside a series
                d.frame()


@_FUZZ
@given(st.binary(max_size=200))
def test_garbage_raises_only_read_error(data: bytes) -> None:
    _read_everything(data)


@_FUZZ
@given(valid_job_metrics(max_metrics=2), st.data())
def test_corrupted_outputs_raise_only_read_error(msg: pb.JobMetrics, data: st.DataObject) -> None:
    wire = bytearray(msg.SerializeToString())
    if not wire:
        return
    for _ in range(data.draw(st.integers(1, 4))):
        pos = data.draw(st.integers(0, len(wire) - 1))
        wire[pos] = data.draw(st.integers(0, 255))
    _read_everything(bytes(wire))


@examples(40)
@given(valid_job_metrics())
def test_generated_outputs_read_back_completely(msg: pb.JobMetrics) -> None:
    wire = msg.SerializeToString(deterministic=True)
    view = read_job_metrics(wire)
    assert view.raw.SerializeToString(deterministic=True) == wire
    frame = view.series_frame()
    assert len(frame) == sum(len(d.frame()) for d in view.data if not d.is_external)


def test_an_index_id_is_read_whether_its_message_is_absent_empty_or_set() -> None:
    # `_data_view` asks whether the index ID's message is there before reading its text.
    index = uuid.UUID(int=7)
    absent = bare_data(pb.DOUBLE_SERIES_DATA_TYPE)
    empty = bare_data(pb.DOUBLE_SERIES_DATA_TYPE)
    empty.index_data_id.SetInParent()
    set_ = bare_data(pb.DOUBLE_SERIES_DATA_TYPE)
    set_.index_data_id.id.data = str(index)
    got = [read_metrics_data(d.SerializeToString()).index_id for d in (absent, empty, set_)]
    assert got == [None, None, index]
