"""The SDK's enums carry the schema's values, written out in stook.sdk._enums (so that
naming a status does not import protobuf): each is checked against the generated module."""

from __future__ import annotations

import enum

import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk._enums import (
    MetricImportance,
    MetricStatus,
    MetricType,
    SeriesKind,
    data_type_of,
    kind_of,
)

# Each enum, the schema's enum and the suffix its value names carry there.
ENUMS = [
    (MetricStatus, "MetricStatus", "_METRIC_STATUS"),
    (MetricImportance, "MetricImportance", "_IMPORTANCE"),
    (MetricType, "MetricType", "_METRIC_TYPE"),
]


@pytest.mark.parametrize(("ours", "schema", "suffix"), ENUMS)
def test_every_member_has_its_schema_value(
    ours: type[enum.IntEnum], schema: str, suffix: str
) -> None:
    values = pb.DESCRIPTOR.enum_types_by_name[schema].values_by_name
    assert {m.name: m.value for m in ours} == {
        name.removesuffix(suffix): v.number
        for name, v in values.items()
        if v.number != 0  # the unset value, which no member stands for
    }


# The schema's name of each series' data type, by (kind, indexed).
DATA_TYPES = {
    (SeriesKind.DOUBLE, False): "DOUBLE_SERIES_DATA_TYPE",
    (SeriesKind.TIMESTAMP, False): "TIMESTAMP_SERIES_DATA_TYPE",
    (SeriesKind.UUID, False): "UUID_SERIES_DATA_TYPE",
    (SeriesKind.STRING, False): "STRING_SERIES_DATA_TYPE",
    (SeriesKind.STATUS, False): "METRIC_STATUS_SERIES_DATA_TYPE",
    (SeriesKind.DOUBLE, True): "INDEXED_DOUBLE_SERIES_DATA_TYPE",
    (SeriesKind.TIMESTAMP, True): "INDEXED_TIMESTAMP_SERIES_DATA_TYPE",
    (SeriesKind.UUID, True): "INDEXED_UUID_SERIES_DATA_TYPE",
    (SeriesKind.STRING, True): "INDEXED_STRING_SERIES_DATA_TYPE",
    (SeriesKind.STATUS, True): "INDEXED_METRIC_STATUS_SERIES_DATA_TYPE",
    (SeriesKind.EXTERNAL_FILE, False): "EXTERNAL_FILE_DATA_TYPE",
}


def test_every_data_type_maps_to_its_schema_value_and_back() -> None:
    for (kind, indexed), name in DATA_TYPES.items():
        value = pb.MetricsDataType.Value(name)
        assert data_type_of(kind, indexed=indexed) == value
        assert kind_of(value) == (kind, indexed)
    # Every data type of the schema but the unset one is mapped.
    assert set(pb.MetricsDataType.values()) - {0} == {
        pb.MetricsDataType.Value(name) for name in DATA_TYPES.values()
    }
