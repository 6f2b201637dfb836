"""A valid output with one metric of each type, built by name, for the validator tests.

Each validator test mutates a fresh `Job` and checks that stook's validator and
ReSim's (the oracle) decide alike; the helpers below reach into its messages.
"""

from __future__ import annotations

import uuid
from collections.abc import Callable
from typing import cast

from resim.metrics.proto import metrics_pb2 as resim_pb
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.proto import metrics_pb2 as pb

_NS = uuid.UUID("00000000-0000-4000-8000-000000000000")
JOB = str(uuid.uuid5(_NS, "job"))


def uid(name: str) -> str:
    return str(uuid.uuid5(_NS, name))


class Job:
    """A valid output with one metric of each type, built by name."""

    def __init__(self) -> None:
        self.msg = pb.JobMetrics()
        self.msg.job_id.id.data = JOB
        self.msg.metrics_status = pb.PASSED_METRIC_STATUS
        self.msg.job_level_metrics.metrics_status = pb.PASSED_METRIC_STATUS
        self._build()

    def data(self, name: str) -> pb.MetricsData:
        return next(d for d in self.msg.metrics_data if d.name == name)

    def metric(self, name: str) -> pb.Metric:
        return next(m for m in self.msg.job_level_metrics.metrics if m.name == name)

    def add_data(
        self, name: str, data_type: int, values: list[object], index: str | None = None
    ) -> pb.MetricsData:
        d = self.msg.metrics_data.add(name=name, data_type=data_type)
        d.metrics_data_id.id.data = uid(name)
        if index is not None:
            d.is_indexed = True
            d.index_data_id.id.data = uid(index)
            d.index_data_type = self.data(index).data_type
        self.fill(d.series, values)
        return d

    @staticmethod
    def fill(series: pb.Series, values: list[object]) -> None:
        first = values[0]
        if isinstance(first, float):
            series.doubles.series.extend(values)  # type: ignore[arg-type]
        elif isinstance(first, tuple):
            for pair in values:
                seconds, nanos = cast(tuple[int, int], pair)
                t = series.timestamps.series.add()
                t.seconds, t.nanos = seconds, nanos
        elif isinstance(first, uuid.UUID):
            for u in values:
                series.uuids.series.add().data = str(u)
        elif isinstance(first, str):
            series.strings.series.extend(values)  # type: ignore[arg-type]
        else:
            series.statuses.series.extend(values)  # type: ignore[arg-type]

    def add_metric(self, name: str, metric_type: int) -> pb.Metric:
        m = self.msg.job_level_metrics.metrics.add(name=name, type=metric_type)
        m.metric_id.id.data = uid(name)
        m.status = pb.PASSED_METRIC_STATUS
        m.importance = pb.HIGH_IMPORTANCE
        m.job_id.id.data = JOB
        return m

    def _build(self) -> None:
        ok = pb.PASSED_METRIC_STATUS
        self.add_data("times", pb.TIMESTAMP_SERIES_DATA_TYPE, [(0, 0), (1, 0), (2, 0)])
        self.add_data("speeds", pb.INDEXED_DOUBLE_SERIES_DATA_TYPE, [1.0, 2.0, 3.0], "times")
        self.add_data(
            "speed statuses", pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE, [ok] * 3, "times"
        )
        self.add_data("values", pb.DOUBLE_SERIES_DATA_TYPE, [0.5, 1.5])
        self.add_data("value statuses", pb.METRIC_STATUS_SERIES_DATA_TYPE, [ok, ok])
        self.add_data("names", pb.STRING_SERIES_DATA_TYPE, ["a", "b"])
        self.add_data("bar values", pb.INDEXED_DOUBLE_SERIES_DATA_TYPE, [1.0, 2.0], "names")
        self.add_data("bar statuses", pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE, [ok] * 2, "names")
        self.add_data("batch ids", pb.UUID_SERIES_DATA_TYPE, [uuid.UUID(int=1)])
        self.add_data("batch values", pb.INDEXED_DOUBLE_SERIES_DATA_TYPE, [1.0], "batch ids")
        self.add_data("batch times", pb.INDEXED_TIMESTAMP_SERIES_DATA_TYPE, [(5, 0)], "batch ids")
        self.add_data(
            "batch statuses", pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE, [ok], "batch ids"
        )
        self.add_data("states", pb.INDEXED_STRING_SERIES_DATA_TYPE, ["idle", "go", "idle"], "times")
        self.add_data(
            "state statuses", pb.INDEXED_METRIC_STATUS_SERIES_DATA_TYPE, [ok] * 3, "times"
        )
        for name, data_type, values in (
            ("grouped", pb.DOUBLE_SERIES_DATA_TYPE, {"car": [1.0], "bike": [2.0, 3.0]}),
            (
                "grouped statuses",
                pb.METRIC_STATUS_SERIES_DATA_TYPE,
                {"car": [ok], "bike": [ok, ok]},
            ),
        ):
            d = self.msg.metrics_data.add(name=name, data_type=data_type, is_per_category=True)
            d.metrics_data_id.id.data = uid(name)
            d.category_names.extend(values)
            for cat, vals in values.items():
                self.fill(d.series_per_category.category_to_series[cat], list(vals))
        picture = self.msg.metrics_data.add(name="picture", data_type=pb.EXTERNAL_FILE_DATA_TYPE)
        picture.metrics_data_id.id.data = uid("picture")
        picture.external_file.path = "a.png"

        self.add_metric(
            "Max speed", pb.SCALAR_METRIC_TYPE
        ).metric_values.scalar_metric_values.value = 3.0
        h = self.add_metric("Speed histogram", pb.HISTOGRAM_METRIC_TYPE)
        hv = h.metric_values.histogram_metric_values
        hv.values_data_id.id.data, hv.statuses_data_id.id.data = (
            uid("values"),
            uid("value statuses"),
        )
        for lower, upper in ((0.0, 1.0), (1.0, 2.5), (2.5, 4.0)):
            hv.buckets.add(lower=lower, upper=upper)
        hv.lower_bound, hv.upper_bound = 0.0, 4.0
        dot = self.add_metric("Speed", pb.DOUBLE_OVER_TIME_METRIC_TYPE)
        dv = dot.metric_values.double_over_time_metric_values
        dv.doubles_over_time_data_id.add().id.data = uid("speeds")
        dv.statuses_over_time_data_id.add().id.data = uid("speed statuses")
        dv.failure_definition.add(fails_above=10.0)
        lp = self.add_metric("Path", pb.LINE_PLOT_METRIC_TYPE).metric_values.line_plot_metric_values
        lp.x_doubles_data_id.add().id.data = uid("values")
        lp.y_doubles_data_id.add().id.data = uid("values")
        lp.statuses_data_id.add().id.data = uid("value statuses")
        bc = self.add_metric("Bars", pb.BAR_CHART_METRIC_TYPE).metric_values.bar_chart_metric_values
        bc.values_data_id.add().id.data = uid("bar values")
        bc.statuses_data_id.add().id.data = uid("bar statuses")
        bw = self.add_metric("Batches", pb.BATCHWISE_BAR_CHART_METRIC_TYPE)
        bwv = bw.metric_values.batchwise_bar_chart_metric_values
        bwv.values_data_id.add().id.data = uid("batch values")
        bwv.times_data_id.add().id.data = uid("batch times")
        bwv.statuses_data_id.add().id.data = uid("batch statuses")
        bwv.categories.append("batch")
        bwv.colors.extend(["#1f77b4", "#1F77B4AA"])
        bwv.project_id.data = uid("project")
        so = self.add_metric("States", pb.STATES_OVER_TIME_METRIC_TYPE)
        sov = so.metric_values.states_over_time_metric_values
        sov.states_over_time_data_id.add().id.data = uid("states")
        sov.statuses_over_time_data_id.add().id.data = uid("state statuses")
        sov.states_set.extend(["idle", "go"])
        sov.failure_states.append("go")
        ds = self.add_metric("Summary", pb.DOUBLE_SUMMARY_METRIC_TYPE)
        dsv = ds.metric_values.double_metric_values
        dsv.value_data_id.id.data, dsv.status_data_id.id.data = (
            uid("grouped"),
            uid("grouped statuses"),
        )
        image = self.add_metric("Image", pb.IMAGE_METRIC_TYPE).metric_values.image_metric_values
        image.image_data_id.id.data = uid("picture")
        images = self.add_metric("Images", pb.IMAGE_LIST_METRIC_TYPE)
        images.metric_values.image_list_metric_values.image_data_ids.add().id.data = uid("picture")
        self.add_metric("Text", pb.TEXT_METRIC_TYPE).metric_values.text_metric_values.text = "hi"
        plot = self.add_metric("Plot", pb.PLOTLY_METRIC_TYPE)
        plot.metric_values.plotly_metric_values.json.update({"data": []})
        stop_speed = self.add_metric("Stop speed", pb.SCALAR_METRIC_TYPE)
        stop_speed.metric_values.scalar_metric_values.value = 0.0
        stop_speed.event_metric = True

        e = self.msg.events.add(name="Stop", status=pb.PASSED_METRIC_STATUS)
        e.event_id.id.data = uid("Stop")
        e.importance = pb.LOW_IMPORTANCE
        e.timestamp_type = pb.ABSOLUTE_TIMESTAMP
        e.timestamp.seconds = 10
        e.metrics.add().id.data = uid("Stop speed")


def resim_accepts(msg: pb.JobMetrics) -> bool:
    try:
        resim_validate(resim_pb.JobMetrics.FromString(msg.SerializeToString()))
    except Exception:  # any failure of ReSim's validator is a refusal
        return False
    return True


Mutation = Callable[[Job], object]


def set_fields(obj: object, **fields: object) -> None:
    for name, value in fields.items():
        setattr(obj, name, value)


def drop_data(name: str) -> Mutation:
    def drop(job: Job) -> None:
        data = job.msg.metrics_data
        del data[[d.name for d in data].index(name)]

    return drop


def hist_values(job: Job) -> pb.HistogramMetricValues:
    return job.metric("Speed histogram").metric_values.histogram_metric_values


def batch_values(job: Job) -> pb.BatchwiseBarChartMetricValues:
    return job.metric("Batches").metric_values.batchwise_bar_chart_metric_values


def states_values(job: Job) -> pb.StatesOverTimeMetricValues:
    return job.metric("States").metric_values.states_over_time_metric_values
