"""Python enums for the schema's enumerations, valued as the proto enums are."""

from __future__ import annotations

import enum

from stook.proto import metrics_pb2 as pb

NANOS_PER_SECOND = 1_000_000_000
"""A schema ``Timestamp`` is seconds and nanos; series and views count UTC nanoseconds."""


class MetricStatus(enum.IntEnum):
    """The status of a metric, a data point or a whole output."""

    PASSED = pb.PASSED_METRIC_STATUS
    FAIL_WARN = pb.FAIL_WARN_METRIC_STATUS
    FAIL_BLOCK = pb.FAIL_BLOCK_METRIC_STATUS
    NOT_APPLICABLE = pb.NOT_APPLICABLE_METRIC_STATUS
    RAW = pb.RAW_METRIC_STATUS

    @classmethod
    def from_api(cls, text: str) -> MetricStatus:
        """Parse the API's spelling (``PASSED``, ``FAIL_WARN``, ...)."""
        try:
            return cls[text]
        except KeyError:
            raise ValueError(f"unknown metric status {text!r}") from None


class MetricImportance(enum.IntEnum):
    ZERO = pb.ZERO_IMPORTANCE
    LOW = pb.LOW_IMPORTANCE
    MEDIUM = pb.MEDIUM_IMPORTANCE
    HIGH = pb.HIGH_IMPORTANCE
    CRITICAL = pb.CRITICAL_IMPORTANCE


class MetricType(enum.IntEnum):
    DOUBLE_SUMMARY = pb.DOUBLE_SUMMARY_METRIC_TYPE
    DOUBLE_OVER_TIME = pb.DOUBLE_OVER_TIME_METRIC_TYPE
    LINE_PLOT = pb.LINE_PLOT_METRIC_TYPE
    BAR_CHART = pb.BAR_CHART_METRIC_TYPE
    STATES_OVER_TIME = pb.STATES_OVER_TIME_METRIC_TYPE
    HISTOGRAM = pb.HISTOGRAM_METRIC_TYPE
    SCALAR = pb.SCALAR_METRIC_TYPE
    PLOTLY = pb.PLOTLY_METRIC_TYPE
    IMAGE = pb.IMAGE_METRIC_TYPE
    BATCHWISE_BAR_CHART = pb.BATCHWISE_BAR_CHART_METRIC_TYPE
    TEXT = pb.TEXT_METRIC_TYPE
    IMAGE_LIST = pb.IMAGE_LIST_METRIC_TYPE


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
    (SeriesKind.DOUBLE, False): pb.DOUBLE_SERIES_DATA_TYPE,
    (SeriesKind.TIMESTAMP, False): pb.TIMESTAMP_SERIES_DATA_TYPE,
    (SeriesKind.UUID, False): pb.UUID_SERIES_DATA_TYPE,
    (SeriesKind.STRING, False): pb.STRING_SERIES_DATA_TYPE,
    (SeriesKind.STATUS, False): pb.METRIC_STATUS_SERIES_DATA_TYPE,
    (SeriesKind.DOUBLE, True): pb.INDEXED_DOUBLE_SERIES_DATA_TYPE,
    (SeriesKind.TIMESTAMP, True): pb.INDEXED_TIMESTAMP_SERIES_DATA_TYPE,
    (SeriesKind.UUID, True): pb.INDEXED_UUID_SERIES_DATA_TYPE,
    (SeriesKind.STRING, True): pb.INDEXED_STRING_SERIES_DATA_TYPE,
    (SeriesKind.STATUS, True): pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE,
    (SeriesKind.EXTERNAL_FILE, False): pb.EXTERNAL_FILE_DATA_TYPE,
}
_KINDS: dict[int, tuple[SeriesKind, bool]] = {v: k for k, v in _DATA_TYPES.items()}


def data_type_of(kind: SeriesKind, *, indexed: bool) -> pb.MetricsDataType.ValueType:
    """The proto MetricsDataType for a series kind, indexed or not."""
    return pb.MetricsDataType.ValueType(_DATA_TYPES[(kind, indexed)])


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
