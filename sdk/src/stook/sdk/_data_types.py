"""The schema's data types grouped as the validator's rules group them, and their names.

ReSim's rules speak of "a timestamp series, indexed or not", "an indexed double
series" and so on; these sets are those groups, shared by the rules of the output
(`_validate`) and of each metric type's values (`_validate_values`). `type_name` and
`type_names` spell data types in problems as the schema does.
"""

from __future__ import annotations

from collections.abc import Set

from stook.proto import metrics_pb2 as pb

TIMESTAMPS = frozenset({pb.TIMESTAMP_SERIES_DATA_TYPE, pb.INDEXED_TIMESTAMP_SERIES_DATA_TYPE})
UUIDS = frozenset({pb.UUID_SERIES_DATA_TYPE, pb.INDEXED_UUID_SERIES_DATA_TYPE})
STRINGS = frozenset({pb.STRING_SERIES_DATA_TYPE, pb.INDEXED_STRING_SERIES_DATA_TYPE})
DOUBLES = frozenset({pb.DOUBLE_SERIES_DATA_TYPE, pb.INDEXED_DOUBLE_SERIES_DATA_TYPE})
STATUSES = frozenset({pb.METRIC_STATUS_SERIES_DATA_TYPE, pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE})
INDEXED = frozenset(
    {
        pb.INDEXED_DOUBLE_SERIES_DATA_TYPE,
        pb.INDEXED_TIMESTAMP_SERIES_DATA_TYPE,
        pb.INDEXED_UUID_SERIES_DATA_TYPE,
        pb.INDEXED_STRING_SERIES_DATA_TYPE,
        pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE,
    }
)
ANY_SERIES = TIMESTAMPS | UUIDS | STRINGS | DOUBLES | STATUSES
INDEXED_DOUBLE = frozenset({pb.INDEXED_DOUBLE_SERIES_DATA_TYPE})


def type_name(value: int) -> str:
    try:
        return pb.MetricsDataType.Name(pb.MetricsDataType.ValueType(value))
    except ValueError:
        return f"unknown data type {value}"


def type_names(values: Set[int]) -> str:
    return " or ".join(sorted(type_name(v) for v in values))
