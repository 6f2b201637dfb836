"""The validator's rules for each kind of metric values, as ReSim applies them.

`ValuesChecker` has one method per field of the ``MetricValues`` oneof, named after
it, plus the pairing rules those share (a value series with its status series, lists
of equal length, external files). It reports through the `OutputChecker` of
`_validate`, whose data lookups it uses, so that every problem lands in one list in
message order.
"""

from __future__ import annotations

import math
import re
from collections.abc import Set
from dataclasses import dataclass
from typing import TYPE_CHECKING

from stook.proto import metrics_pb2 as pb
from stook.sdk._data_types import (
    ANY_SERIES,
    DOUBLES,
    INDEXED,
    INDEXED_DOUBLE,
    STRINGS,
    TIMESTAMPS,
    UUIDS,
    type_name,
    type_names,
)

if TYPE_CHECKING:
    from stook.sdk._validate import OutputChecker

# ReSim's pattern is `^#([0-9a-fA-F]{2}){3,4}$` with re.search, and `$` also
# matches before one final newline; \n?\Z keeps that.
_HEX_COLOR = re.compile(r"\A#(?:[0-9a-fA-F]{2}){3,4}\n?\Z")


@dataclass
class ValuesChecker:
    """The rules of each kind of metric values, for one metric."""

    job: OutputChecker
    where: str

    def add(self, rule: str) -> None:
        self.job.add(self.where, rule)

    def check(self, values: pb.MetricValues) -> None:
        which = values.WhichOneof("metric_values")
        if which is None:
            self.add("the metric has no values")
            return
        check = getattr(self, f"check_{which}")
        check(getattr(values, which))

    # Each method is named after the MetricValues oneof field it checks.

    def check_double_metric_values(self, v: pb.DoubleSummaryMetricValues) -> None:
        allowed_values: Set[int]
        index = v.WhichOneof("index")
        if index == "timestamp_index":
            allowed_values, allowed_index = INDEXED_DOUBLE, TIMESTAMPS
        elif index == "uuid_index":
            allowed_values, allowed_index = INDEXED_DOUBLE, UUIDS
        elif index == "string_index":
            allowed_values, allowed_index = INDEXED_DOUBLE, STRINGS
        else:
            allowed_values, allowed_index = DOUBLES, ANY_SERIES
        self.values_and_statuses(
            "value", v.value_data_id, v.status_data_id, allowed_values, allowed_index
        )

    def check_double_over_time_metric_values(self, v: pb.DoubleOverTimeMetricValues) -> None:
        n = len(v.doubles_over_time_data_id)
        self.same_lengths(
            ("doubles", n),
            ("statuses", len(v.statuses_over_time_data_id)),
            ("failure definitions", len(v.failure_definition)),
        )
        for values, statuses in zip(
            v.doubles_over_time_data_id, v.statuses_over_time_data_id, strict=False
        ):
            self.values_and_statuses("doubles", values, statuses, INDEXED_DOUBLE, TIMESTAMPS)

    def check_line_plot_metric_values(self, v: pb.LinePlotMetricValues) -> None:
        self.same_lengths(
            ("x data", len(v.x_doubles_data_id)),
            ("y data", len(v.y_doubles_data_id)),
            ("statuses", len(v.statuses_data_id)),
        )
        for x, y, statuses in zip(
            v.x_doubles_data_id, v.y_doubles_data_id, v.statuses_data_id, strict=False
        ):
            self.values_and_statuses("x", x, statuses, DOUBLES, TIMESTAMPS)
            self.values_and_statuses("y", y, statuses, DOUBLES, TIMESTAMPS)

    def check_bar_chart_metric_values(self, v: pb.BarChartMetricValues) -> None:
        self.same_lengths(("values", len(v.values_data_id)), ("statuses", len(v.statuses_data_id)))
        for values, statuses in zip(v.values_data_id, v.statuses_data_id, strict=False):
            self.values_and_statuses("values", values, statuses, INDEXED_DOUBLE, STRINGS)

    def check_batchwise_bar_chart_metric_values(self, v: pb.BatchwiseBarChartMetricValues) -> None:
        self.same_lengths(
            ("values", len(v.values_data_id)),
            ("times", len(v.times_data_id)),
            ("statuses", len(v.statuses_data_id)),
            ("categories", len(v.categories)),
        )
        for n, color in enumerate(v.colors):
            if not _HEX_COLOR.search(color):
                self.add(f"colour {n} ({color!r}) is not a hex colour like '#1f77b4'")
        self.job.check_id(self.where, "project id", v.project_id)
        for values, times, statuses in zip(
            v.values_data_id, v.times_data_id, v.statuses_data_id, strict=False
        ):
            self.values_and_statuses("values", values, statuses, INDEXED_DOUBLE, UUIDS)
            self.values_and_statuses(
                "times",
                times,
                statuses,
                frozenset({pb.INDEXED_TIMESTAMP_SERIES_DATA_TYPE}),
                UUIDS,
            )

    def check_states_over_time_metric_values(self, v: pb.StatesOverTimeMetricValues) -> None:
        self.same_lengths(
            ("states", len(v.states_over_time_data_id)),
            ("statuses", len(v.statuses_over_time_data_id)),
        )
        states_set = set(v.states_set)
        pairs = list(zip(v.states_over_time_data_id, v.statuses_over_time_data_id, strict=False))
        for states, statuses in pairs:
            if not self.values_and_statuses(
                "states",
                states,
                statuses,
                frozenset({pb.INDEXED_STRING_SERIES_DATA_TYPE}),
                TIMESTAMPS,
            ):
                continue
            data = self.job.data_by_id[states.id.data]
            if data.HasField("series"):
                series_list = [data.series]
            else:
                by_category = data.series_per_category.category_to_series
                series_list = [by_category[c] for c in sorted(by_category)]
            for series in series_list:
                if not series.HasField("strings"):
                    self.add(f"the states data {data.name!r} must hold strings")
                    continue
                unknown = sorted(set(series.strings.series) - states_set)
                if unknown:
                    self.add(f"states {unknown} of {data.name!r} are not in the states set")
        # ReSim checks this once per pair: with no pairs it is never checked.
        if pairs and not set(v.failure_states) <= states_set:
            extra = sorted(set(v.failure_states) - states_set)
            self.add(f"failure states {extra} are not in the states set")

    def check_histogram_metric_values(self, v: pb.HistogramMetricValues) -> None:
        self.values_and_statuses(
            "values", v.values_data_id, v.statuses_data_id, DOUBLES, ANY_SERIES
        )
        if not v.buckets:
            self.add("a histogram needs at least one bucket")
            return
        previous_upper: float | None = None
        for n, bucket in enumerate(v.buckets):
            if previous_upper is None:
                # Unset bounds read as 0.0, as in ReSim.
                if bucket.lower != v.lower_bound:
                    self.add(
                        f"histogram bucket 0 starts at {bucket.lower}, "
                        f"but lower_bound is {v.lower_bound}"
                    )
            elif bucket.lower != previous_upper:
                self.add(
                    f"histogram buckets must be contiguous (bucket {n} starts at "
                    f"{bucket.lower}, previous ended at {previous_upper})"
                )
            # Negated, so that NaN bounds are refused, as ReSim's `lower < upper`.
            if not bucket.lower < bucket.upper:
                self.add(
                    f"histogram bucket {n} must end after it starts "
                    f"({bucket.lower} to {bucket.upper})"
                )
            previous_upper = bucket.upper
        if previous_upper != v.upper_bound:
            self.add(
                f"the last histogram bucket ends at {previous_upper}, "
                f"but upper_bound is {v.upper_bound}"
            )

    def check_scalar_metric_values(self, v: pb.ScalarMetricValues) -> None:
        if not v.HasField("value"):
            self.add("a scalar metric needs a value")
        elif math.isnan(v.value):
            self.add("a scalar metric value cannot be NaN")

    def check_plotly_metric_values(self, v: pb.PlotlyMetricValues) -> None:
        if not v.HasField("json"):
            self.add("a plotly metric needs its JSON")

    def check_text_metric_values(self, v: pb.TextMetricValues) -> None:
        if not v.text:
            self.add("a text metric needs non-empty text")

    def check_image_metric_values(self, v: pb.ImageMetricValues) -> None:
        if not v.HasField("image_data_id"):
            self.add("an image metric needs an image data id")
            return
        self.external_file("image", v.image_data_id)

    def check_image_list_metric_values(self, v: pb.ImageListMetricValues) -> None:
        if not v.image_data_ids:
            self.add("an image list metric needs at least one image")
        for n, ref in enumerate(v.image_data_ids):
            self.external_file(f"image {n}", ref)

    # ------------------------------------------------------------ shared rules

    def external_file(self, role: str, ref: pb.MetricsDataId) -> None:
        data = self.job.find_data(self.where, role, ref)
        if data is not None and data.data_type != pb.EXTERNAL_FILE_DATA_TYPE:
            self.add(
                f"{role} data {data.name!r} must be EXTERNAL_FILE_DATA_TYPE, "
                f"not {type_name(data.data_type)}"
            )

    def same_lengths(self, *counts: tuple[str, int]) -> None:
        if len({n for _, n in counts}) > 1:
            listed = ", ".join(f"{n} {what}" for what, n in counts)
            self.add(f"the lists of data must have the same length (got {listed})")

    def values_and_statuses(
        self,
        role: str,
        value_ref: pb.MetricsDataId,
        status_ref: pb.MetricsDataId,
        allowed_values: Set[int],
        allowed_index: Set[int],
    ) -> bool:
        """ReSim's pairing of a value data with its status data; True if all is well."""
        before = len(self.job.problems)
        values = self.job.find_data(self.where, f"{role}", value_ref)
        if values is not None and values.data_type not in allowed_values:
            self.add(
                f"{role} data {values.name!r} is {type_name(values.data_type)}, "
                f"but must be {type_names(allowed_values)}"
            )
        statuses = self.job.find_data(self.where, f"{role} status", status_ref)
        if values is None or statuses is None:
            return False
        if values.data_type not in INDEXED:
            self.require_type(role, statuses, pb.METRIC_STATUS_SERIES_DATA_TYPE)
        else:
            self.require_type(role, statuses, pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE)
            if statuses.index_data_id != values.index_data_id:
                self.add(
                    f"status data {statuses.name!r} must have the same index as "
                    f"{role} data {values.name!r}"
                )
            for data in (statuses, values):
                if data.index_data_type not in allowed_index:
                    self.add(
                        f"the index of {data.name!r} is {type_name(data.index_data_type)}, "
                        f"but must be {type_names(allowed_index)}"
                    )
        self.job.check_agree(self.where, "its status data", values, statuses)
        return len(self.job.problems) == before

    def require_type(self, role: str, statuses: pb.MetricsData, wanted: int) -> None:
        if statuses.data_type != wanted:
            self.add(
                f"{role} status data {statuses.name!r} is {type_name(statuses.data_type)}, "
                f"but must be {type_name(wanted)}"
            )
