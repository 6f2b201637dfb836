"""stook.v1's schema is wire-compatible with ReSim's resim.metrics.proto.

Every message and enum of ReSim's metrics.proto (and its UUID) must exist in
stook's schema under the same name with the same fields and values; only the
package differs. A round trip through both proves the bytes interchange.
"""

from __future__ import annotations

import math
import uuid

import pytest
from google.protobuf.descriptor import Descriptor, EnumDescriptor, FieldDescriptor
from resim.metrics.proto import metrics_pb2 as resim_pb
from resim.utils.proto import uuid_pb2 as resim_uuid_pb

from stook.proto import metrics_pb2 as pb
from stook.proto import uuid_pb2

_PACKAGES = {"resim.metrics.proto": "stook.v1", "resim.proto": "stook.v1"}


def _local(full_name: str) -> str:
    """A type name with ReSim's packages replaced by stook's."""
    for theirs, ours in _PACKAGES.items():
        if full_name.startswith(theirs + "."):
            return ours + full_name[len(theirs) :]
    return full_name


def _all_messages(messages: list[Descriptor]) -> list[Descriptor]:
    found: list[Descriptor] = []
    for message in messages:
        found.append(message)
        found.extend(_all_messages(list(message.nested_types)))
    return found


def _field_signature(fd: FieldDescriptor) -> dict[str, object]:
    return {
        "number": fd.number,
        "type": fd.type,
        "repeated": fd.is_repeated,
        "has_presence": fd.has_presence,
        "oneof": fd.containing_oneof.name if fd.containing_oneof else None,
        # In proto3 an `optional` field is a synthetic one-field oneof named _<field>.
        "proto3_optional": bool(
            fd.containing_oneof is not None and fd.containing_oneof.name == f"_{fd.name}"
        ),
        "map": bool(fd.message_type is not None and fd.message_type.GetOptions().map_entry),
        "message_type": _local(fd.message_type.full_name) if fd.message_type else None,
        "enum_type": _local(fd.enum_type.full_name) if fd.enum_type else None,
        "packed": fd.is_packed,
    }


def _message_signature(message: Descriptor) -> dict[str, dict[str, object]]:
    return {fd.name: _field_signature(fd) for fd in message.fields}


def _enum_signature(enum: EnumDescriptor) -> dict[str, int]:
    return {value.name: value.number for value in enum.values}


_RESIM_MESSAGES = _all_messages(list(resim_pb.DESCRIPTOR.message_types_by_name.values()))
_STOOK_MESSAGES = {
    m.full_name: m for m in _all_messages(list(pb.DESCRIPTOR.message_types_by_name.values()))
}


@pytest.mark.parametrize("theirs", _RESIM_MESSAGES, ids=lambda m: m.full_name)
def test_message_matches(theirs: Descriptor) -> None:
    ours = _STOOK_MESSAGES.get(_local(theirs.full_name))
    assert ours is not None, f"stook lacks message {theirs.full_name}"
    assert _message_signature(ours) == _message_signature(theirs)
    assert sorted(o.name for o in ours.oneofs) == sorted(o.name for o in theirs.oneofs)


def test_no_extra_messages_or_enums() -> None:
    assert set(_STOOK_MESSAGES) == {_local(m.full_name) for m in _RESIM_MESSAGES}
    assert set(pb.DESCRIPTOR.enum_types_by_name) == set(resim_pb.DESCRIPTOR.enum_types_by_name)


@pytest.mark.parametrize(
    "theirs", list(resim_pb.DESCRIPTOR.enum_types_by_name.values()), ids=lambda e: e.name
)
def test_enum_matches(theirs: EnumDescriptor) -> None:
    ours = pb.DESCRIPTOR.enum_types_by_name[theirs.name]
    assert _enum_signature(ours) == _enum_signature(theirs)


def test_uuid_matches() -> None:
    ours, theirs = uuid_pb2.UUID.DESCRIPTOR, resim_uuid_pb.UUID.DESCRIPTOR
    assert _message_signature(ours) == _message_signature(theirs)


def test_same_syntax_and_dependencies() -> None:
    assert {d.name for d in resim_pb.DESCRIPTOR.dependencies} - {
        "resim/utils/proto/uuid.proto"
    } == {d.name for d in pb.DESCRIPTOR.dependencies} - {"stook/proto/uuid.proto"}


def _id(text: str | None = None) -> str:
    return text or str(uuid.uuid4())


def _everything() -> resim_pb.JobMetrics:
    """A ReSim message that sets every field of every message at least once."""
    job = resim_pb.JobMetrics()
    job.job_id.id.data = _id()
    job.metrics_status = resim_pb.FAIL_BLOCK_METRIC_STATUS

    d = job.metrics_data.add()
    d.metrics_data_id.id.data = _id()
    d.data_type = resim_pb.INDEXED_DOUBLE_SERIES_DATA_TYPE
    d.name, d.unit = "speeds", "m/s"
    d.is_per_category = True
    d.category_names.extend(["car", "bike"])
    d.is_indexed = True
    d.index_data_id.id.data = _id()
    d.index_data_type = resim_pb.TIMESTAMP_SERIES_DATA_TYPE
    d.series_per_category.category_to_series["car"].doubles.series.extend(
        [1.0, -0.0, math.inf, math.nan, 5e-324]
    )
    d.series_per_category.category_to_series["bike"].doubles.series.extend([2.0])
    for kind in ("timestamps", "uuids", "strings", "statuses"):
        s = job.metrics_data.add()
        s.name = kind
        s.data_type = resim_pb.STRING_SERIES_DATA_TYPE
        if kind == "timestamps":
            t = s.series.timestamps.series.add()
            t.seconds, t.nanos = 1_700_000_000, 123
        elif kind == "uuids":
            s.series.uuids.series.add().data = _id()
        elif kind == "strings":
            s.series.strings.series.extend(["a", "ü", ""])
        else:
            s.series.statuses.series.extend([1, 2, 3, 4, 5, 0, 42])
    f = job.metrics_data.add()
    f.external_file.path = "images/a.png"

    metrics = job.job_level_metrics
    metrics.metrics_status = resim_pb.PASSED_METRIC_STATUS
    m = metrics.metrics.add()
    m.metric_id.id.data = _id()
    m.name, m.description = "m", "d"
    m.type, m.status = resim_pb.SCALAR_METRIC_TYPE, resim_pb.RAW_METRIC_STATUS
    m.should_display, m.blocking, m.event_metric = False, True, True
    m.importance = resim_pb.CRITICAL_IMPORTANCE
    m.job_id.id.data = job.job_id.id.data
    m.order = 1.5
    tag = m.tags.add()
    tag.key, tag.value = "k", "v"
    sc = m.metric_values.scalar_metric_values
    sc.value, sc.unit = 3.25, "m"
    sc.failure_definition.fails_above = 1.0
    sc.failure_definition.fails_below = 0.0

    values = []
    for name in resim_pb.MetricValues.DESCRIPTOR.fields_by_name:
        v = metrics.metrics.add().metric_values
        values.append(getattr(v, name))
        getattr(v, name).SetInParent()
    ds = metrics.metrics.add().metric_values.double_metric_values
    ds.value_data_id.id.data = ds.status_data_id.id.data = _id()
    ds.uuid_index.data = _id()
    ds.failure_definition.fails_below = 2.0
    ds2 = metrics.metrics.add().metric_values.double_metric_values
    ds2.timestamp_index.seconds = 3
    metrics.metrics.add().metric_values.double_metric_values.series_index = 7
    metrics.metrics.add().metric_values.double_metric_values.string_index = "car"
    dot = metrics.metrics.add().metric_values.double_over_time_metric_values
    dot.doubles_over_time_data_id.add().id.data = _id()
    dot.statuses_over_time_data_id.add().id.data = _id()
    dot.failure_definition.add().fails_above = 9.0
    dot.start_time.seconds, dot.end_time.seconds = 1, 2
    dot.y_axis_name = "y"
    dot.legend_series_names.append("l")
    lp = metrics.metrics.add().metric_values.line_plot_metric_values
    lp.x_doubles_data_id.add().id.data = _id()
    lp.y_doubles_data_id.add().id.data = _id()
    lp.statuses_data_id.add().id.data = _id()
    lp.x_axis_name, lp.y_axis_name = "x", "y"
    lp.legend_series_names.append("l")
    bc = metrics.metrics.add().metric_values.bar_chart_metric_values
    bc.values_data_id.add().id.data = _id()
    bc.statuses_data_id.add().id.data = _id()
    bc.legend_series_names.append("l")
    bc.x_axis_name, bc.y_axis_name, bc.stack_bars = "x", "y", False
    bw = metrics.metrics.add().metric_values.batchwise_bar_chart_metric_values
    bw.times_data_id.add().id.data = _id()
    bw.values_data_id.add().id.data = _id()
    bw.statuses_data_id.add().id.data = _id()
    bw.categories.append("c")
    bw.colors.append("#aabbcc")
    bw.x_axis_name, bw.y_axis_name, bw.stack_bars = "x", "y", True
    bw.project_id.data = _id()
    so = metrics.metrics.add().metric_values.states_over_time_metric_values
    so.states_over_time_data_id.add().id.data = _id()
    so.statuses_over_time_data_id.add().id.data = _id()
    so.states_set.extend(["a", "b"])
    so.failure_states.append("b")
    so.legend_series_names.append("l")
    h = metrics.metrics.add().metric_values.histogram_metric_values
    h.values_data_id.id.data = h.statuses_data_id.id.data = _id()
    b = h.buckets.add()
    b.lower, b.upper = 0.0, 1.0
    h.buckets.add().lower = 1.0
    h.lower_bound, h.upper_bound, h.x_axis_name = 0.0, 2.0, "x"
    pl = metrics.metrics.add().metric_values.plotly_metric_values
    pl.json.update({"data": [1, "two", None, True, {"x": 2.5}]})
    metrics.metrics.add().metric_values.image_metric_values.image_data_id.id.data = _id()
    metrics.metrics.add().metric_values.image_list_metric_values.image_data_ids.add().id.data = (
        _id()
    )
    metrics.metrics.add().metric_values.text_metric_values.text = "hello"

    e = job.events.add()
    e.event_id.id.data = _id()
    e.name, e.description = "stop", "d"
    e.tags.extend(["t1", "t2"])
    e.metrics.add().id.data = m.metric_id.id.data
    e.status = resim_pb.FAIL_WARN_METRIC_STATUS
    e.timestamp.seconds, e.timestamp.nanos = 10, 5
    e.importance = resim_pb.LOW_IMPORTANCE
    e.timestamp_type = resim_pb.RELATIVE_TIMESTAMP
    return job


def _set_field_paths(msg: object, prefix: str = "") -> set[str]:
    paths: set[str] = set()
    for fd, value in msg.ListFields():  # type: ignore[attr-defined]
        path = f"{prefix}{_local(fd.containing_type.full_name)}.{fd.name}"
        paths.add(path)
        if fd.message_type is None:
            continue
        if fd.message_type.GetOptions().map_entry:
            items = list(value.values())
        elif fd.is_repeated:
            items = list(value)
        else:
            items = [value]
        for item in items:
            if hasattr(item, "ListFields"):
                paths |= _set_field_paths(item)
    return paths


def test_round_trip_every_field_is_byte_identical() -> None:
    theirs = _everything()
    wire = theirs.SerializeToString(deterministic=True)
    ours = pb.JobMetrics.FromString(wire)
    assert ours.SerializeToString(deterministic=True) == wire
    back = resim_pb.JobMetrics.FromString(ours.SerializeToString(deterministic=True))
    assert back == theirs


def test_round_trip_sets_every_metrics_field() -> None:
    # The round trip above only proves something for fields it sets.
    covered = _set_field_paths(pb.JobMetrics.FromString(_everything().SerializeToString()))
    every = {
        f"{m.full_name}.{fd.name}"
        for m in _STOOK_MESSAGES.values()
        if not m.GetOptions().map_entry
        for fd in m.fields
    }
    assert every - covered == set()
