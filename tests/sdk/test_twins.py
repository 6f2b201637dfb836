"""Views written through a writable twin (`stook.sdk.fastpaths`) are the dataclass's own."""

from __future__ import annotations

import dataclasses
import pickle
import uuid

import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk import MetricsDataView, SeriesKind, read_metrics_data
from stook.sdk.fastpaths import writable_twin
from tests.sdk.support import bare_data

DATA_ID = uuid.UUID("418e78d2-c5d6-576c-af09-0f8c761e8ee8")
INDEX_ID = uuid.UUID("7d0c1f5e-2b3a-4c5d-8e9f-0a1b2c3d4e5f")


def _message(**fields: object) -> pb.MetricsData:
    d = bare_data(pb.INDEXED_DOUBLE_SERIES_DATA_TYPE, unit="m/s", is_indexed=True, **fields)
    d.metrics_data_id.id.data = str(DATA_ID)
    d.index_data_id.id.data = str(INDEX_ID).upper()
    d.index_data_type = pb.TIMESTAMP_SERIES_DATA_TYPE
    return d


def _built(msg: pb.MetricsData, source: str) -> MetricsDataView:
    """The view `read_metrics_data` gives, built through the dataclass's own __init__."""
    return MetricsDataView(
        id=DATA_ID,
        name="d",
        unit="m/s",
        kind=SeriesKind.DOUBLE,
        indexed=True,
        index_id=INDEX_ID,
        index_kind=SeriesKind.TIMESTAMP,
        per_category=msg.is_per_category,
        categories=tuple(msg.category_names),
        external_path=None,
        raw=msg,
        source=source,
    )


@pytest.mark.parametrize(
    "msg",
    [_message(), _message(is_per_category=True, category_names=["b", "a"])],
    ids=["plain", "per-category"],
)
def test_a_read_view_is_the_dataclass_own(msg: pb.MetricsData) -> None:
    if msg.is_per_category:
        msg.series_per_category.category_to_series["a"].doubles.series.append(1.5)
    else:
        msg.series.doubles.series.append(1.5)
    view = read_metrics_data(msg.SerializeToString(), source="v.bin")
    expected = _built(view.raw, "v.bin")
    assert type(view) is MetricsDataView
    # Every field is set (a field the reader forgot would raise AttributeError here).
    assert [getattr(view, f.name) for f in dataclasses.fields(view)] == [
        getattr(expected, f.name) for f in dataclasses.fields(expected)
    ]
    assert view == expected
    with pytest.raises(TypeError, match="unhashable type: 'MetricsData'"):
        hash(view)  # the dataclass's own __hash__, which hashes `raw`, as for `expected`
    assert repr(view) == repr(expected)
    assert pickle.loads(pickle.dumps(view)) == view
    assert dataclasses.replace(view, unit="km/h").unit == "km/h"
    with pytest.raises(dataclasses.FrozenInstanceError):
        view.name = "other"  # type: ignore[misc]
    # A new attribute fails as it fails on any view (a TypeError from the frozen
    # __setattr__ on Python 3.11).
    errors = []
    for frozen in (view, expected):
        with pytest.raises((TypeError, AttributeError)) as info:
            frozen.extra = 1  # type: ignore[attr-defined]
        errors.append((type(info.value), str(info.value)))
    assert errors[0] == errors[1]


def test_a_twin_needs_slots_that_are_the_fields() -> None:
    @dataclasses.dataclass(frozen=True)
    class NoSlots:
        a: int

    @dataclasses.dataclass(frozen=True, slots=True, weakref_slot=True)
    class MoreSlots:
        a: int

    for cls in (NoSlots, MoreSlots):
        with pytest.raises(TypeError, match="its slots are not its fields"):
            writable_twin(cls)
    twin = writable_twin(MetricsDataView)
    assert twin.__slots__ == MetricsDataView.__slots__  # type: ignore[attr-defined]
