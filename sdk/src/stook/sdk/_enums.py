"""Python enums for the schema's enumerations, valued as the proto enums are.

The values are written out rather than read from `stook.proto`: they are the wire
format's, fixed by the schema, and importing the generated module (protobuf with it,
~15 ms) would make every module that names a status pay for it, `stook run` before its
first request included. tests/sdk/test_enums.py checks every value against the schema.
"""

from __future__ import annotations

import enum
from typing import TYPE_CHECKING, cast

if TYPE_CHECKING:
    from stook.proto import metrics_pb2 as pb

NANOS_PER_SECOND = 1_000_000_000
"""A schema ``Timestamp`` is seconds and nanos; series and views count UTC nanoseconds."""


class MetricStatus(enum.IntEnum):
    """The status of a metric, a data point or a whole output."""

    PASSED = 1
    FAIL_WARN = 2
    FAIL_BLOCK = 5
    NOT_APPLICABLE = 3
    RAW = 4

    @classmethod
    def from_api(cls, text: str) -> MetricStatus:
        """Parse the API's spelling (``PASSED``, ``FAIL_WARN``, ...)."""
        try:
            return cls[text]
        except KeyError:
            raise ValueError(f"unknown metric status {text!r}") from None


class MetricImportance(enum.IntEnum):
    ZERO = 1
    LOW = 2
    MEDIUM = 3
    HIGH = 4
    CRITICAL = 5


class MetricType(enum.IntEnum):
    DOUBLE_SUMMARY = 1
    DOUBLE_OVER_TIME = 2
    LINE_PLOT = 3
    BAR_CHART = 4
    STATES_OVER_TIME = 5
    HISTOGRAM = 6
    SCALAR = 7
    PLOTLY = 8
    IMAGE = 9
    BATCHWISE_BAR_CHART = 10
    TEXT = 11
    IMAGE_LIST = 12


class SeriesKind(enum.Enum):
    """What one element of a metrics-data series is."""

    DOUBLE = "double"
    TIMESTAMP = "timestamp"
    UUID = "uuid"
    STRING = "string"
    STATUS = "status"
    EXTERNAL_FILE = "external_file"


# (kind, indexed) -> proto MetricsDataType, and back.
_DATA_TYPES: dict[tuple[SeriesKind, bool], int] = {
    (SeriesKind.DOUBLE, False): 1,  # DOUBLE_SERIES_DATA_TYPE
    (SeriesKind.TIMESTAMP, False): 2,  # TIMESTAMP_SERIES_DATA_TYPE
    (SeriesKind.UUID, False): 3,  # UUID_SERIES_DATA_TYPE
    (SeriesKind.STRING, False): 4,  # STRING_SERIES_DATA_TYPE
    (SeriesKind.STATUS, False): 5,  # METRIC_STATUS_SERIES_DATA_TYPE
    (SeriesKind.DOUBLE, True): 6,  # INDEXED_DOUBLE_SERIES_DATA_TYPE
    (SeriesKind.TIMESTAMP, True): 7,  # INDEXED_TIMESTAMP_SERIES_DATA_TYPE
    (SeriesKind.UUID, True): 8,  # INDEXED_UUID_SERIES_DATA_TYPE
    (SeriesKind.STRING, True): 9,  # INDEXED_STRING_SERIES_DATA_TYPE
    (SeriesKind.STATUS, True): 10,  # INDEXED_METRIC_STATUS_SERIES_DATA_TYPE
    (SeriesKind.EXTERNAL_FILE, False): 11,  # EXTERNAL_FILE_DATA_TYPE
}
_KINDS: dict[int, tuple[SeriesKind, bool]] = {v: k for k, v in _DATA_TYPES.items()}


def data_type_of(kind: SeriesKind, *, indexed: bool) -> pb.MetricsDataType.ValueType:
    """The proto MetricsDataType for a series kind, indexed or not."""
    return cast("pb.MetricsDataType.ValueType", _DATA_TYPES[(kind, indexed)])


def kind_of(data_type: int) -> tuple[SeriesKind, bool]:
    """(kind, indexed) for a proto MetricsDataType; ValueError for NO_DATA_TYPE or unknown."""
    try:
        return _KINDS[data_type]
    except KeyError:
        raise ValueError(f"unknown or unset metrics data type {data_type}") from None


# The element field of a proto Series for each kind.
SERIES_FIELD: dict[SeriesKind, str] = {
    SeriesKind.DOUBLE: "doubles",
    SeriesKind.TIMESTAMP: "timestamps",
    SeriesKind.UUID: "uuids",
    SeriesKind.STRING: "strings",
    SeriesKind.STATUS: "statuses",
}
