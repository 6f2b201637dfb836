"""Every API model as its answer's decoder reads it, checked against JSON produced by ReSim's
own client models."""

from __future__ import annotations

import json
import random
import uuid
from datetime import UTC, datetime, timedelta, timezone
from typing import Any, TypeVar

import msgspec
import pytest
from resim.sdk.client.models import (
    Batch as ResimBatch,
)
from resim.sdk.client.models import (
    BatchMetric as ResimBatchMetric,
)
from resim.sdk.client.models import (
    BatchMetricsData as ResimBatchMetricsData,
)
from resim.sdk.client.models import (
    Build as ResimBuild,
)
from resim.sdk.client.models import (
    CustomFieldDefinition as ResimCustomField,
)
from resim.sdk.client.models import (
    Experience as ResimExperience,
)
from resim.sdk.client.models import (
    Job as ResimJob,
)
from resim.sdk.client.models import (
    JobMetric as ResimJobMetric,
)
from resim.sdk.client.models import (
    JobMetricsData as ResimJobMetricsData,
)
from resim.sdk.client.models import (
    Report as ResimReport,
)
from resim.sdk.client.models.batch_status import BatchStatus as ResimBatchStatus
from resim.sdk.client.models.conflated_batch_status import (
    ConflatedBatchStatus as ResimConflatedBatchStatus,
)
from resim.sdk.client.models.conflated_job_status import (
    ConflatedJobStatus as ResimConflatedJobStatus,
)
from resim.sdk.client.models.custom_field_value_type import (
    CustomFieldValueType as ResimCustomFieldType,
)
from resim.sdk.client.models.job_status import JobStatus as ResimJobStatus
from resim.sdk.client.models.metric_status import MetricStatus as ResimMetricStatus
from resim.sdk.client.models.metric_type import MetricType as ResimMetricType
from resim.sdk.client.models.metrics_data_type import MetricsDataType as ResimMetricsDataType
from resim.sdk.client.models.report_status import ReportStatus as ResimReportStatus

from stook.service.api._models import (
    ApiMetric,
    ApiMetricsData,
    ApiMetricStatus,
    ApiMetricType,
    Batch,
    BatchMetric,
    BatchMetricsData,
    BatchStatus,
    Build,
    ConflatedBatchStatus,
    ConflatedJobStatus,
    CustomField,
    CustomFieldType,
    Experience,
    Job,
    JobLog,
    JobStatus,
    MetricOwner,
    MetricsDataStorageType,
    Report,
    Timestamp,
    decoder,
    parse_rfc3339,
)

_M = TypeVar("_M")

NOW = Timestamp(2025, 3, 4, 5, 6, 7, 891011, tzinfo=UTC)
# Random-looking but the same in every process: they name parametrized tests, which
# pytest-xdist's workers must collect alike.
IDS = [uuid.UUID(int=random.Random(n).getrandbits(128), version=4) for n in range(8)]


def decode(model: type[_M], wire: Any) -> _M:
    """`model` as the decoder of an answer holding it reads it from `wire` as JSON."""
    return decoder(model).decode(json.dumps(wire))


def as_wire(resim_model: Any) -> dict[str, Any]:
    """What the API would send: ReSim's model serialised to JSON and read back."""
    wire: dict[str, Any] = json.loads(json.dumps(resim_model.to_dict()))
    return wire


@pytest.mark.parametrize(
    ("ours", "theirs"),
    [
        (ConflatedJobStatus, ResimConflatedJobStatus),
        (JobStatus, ResimJobStatus),
        (BatchStatus, ResimBatchStatus),
        (ConflatedBatchStatus, ResimConflatedBatchStatus),
        (ApiMetricStatus, ResimMetricStatus),
        (ApiMetricType, ResimMetricType),
        (MetricsDataStorageType, ResimMetricsDataType),
        (CustomFieldType, ResimCustomFieldType),
    ],
)
def test_enums_match_resim(ours: Any, theirs: Any) -> None:
    assert {member.value for member in ours} == {member.value for member in theirs}


def test_job_from_resim_json() -> None:
    wire = as_wire(
        ResimJob(
            job_id=str(IDS[0]),
            batch_id=str(IDS[1]),
            project_id=str(IDS[2]),
            experience_id=str(IDS[3]),
            experience_name="left turn",
            build_id=str(IDS[4]),
            conflated_status=ResimConflatedJobStatus.WARNING,
            job_status=ResimJobStatus.SUCCEEDED,
            job_metrics_status=ResimMetricStatus.FAIL_WARN,
            creation_timestamp=NOW,
            description="extra fields are ignored",
            worker_id="w-1",
        )
    )
    job = decode(Job, wire)
    assert job == Job(
        job_id=IDS[0],
        batch_id=IDS[1],
        project_id=IDS[2],
        experience_id=IDS[3],
        experience_name="left turn",
        build_id=IDS[4],
        conflated_status=ConflatedJobStatus.WARNING,
        job_status=JobStatus.SUCCEEDED,
        job_metrics_status=ApiMetricStatus.FAIL_WARN,
        creation_timestamp=NOW,
    )


def test_job_metric_and_batch_metric_from_resim_json() -> None:
    common: dict[str, Any] = {
        "metric_id": str(IDS[0]),
        "name": "max speed",
        "type_": ResimMetricType.SCALAR,
        "status": ResimMetricStatus.PASSED,
        "value": 12.5,
        "unit": "m/s",
        "metric_url": "https://storage.example.com/m.binproto?X-Amz-Signature=abc",
        "data_i_ds": [str(IDS[1]), str(IDS[2])],
        "event_metric": False,
        "creation_timestamp": NOW,
        "batch_id": str(IDS[3]),
    }
    job_metric = decode(ApiMetric, as_wire(ResimJobMetric(**common, job_id=str(IDS[4]))))
    assert job_metric.metric_id == IDS[0]
    assert job_metric.type == ApiMetricType.SCALAR
    assert job_metric.status == ApiMetricStatus.PASSED
    assert job_metric.value == 12.5
    assert job_metric.unit == "m/s"
    assert job_metric.data_ids == (IDS[1], IDS[2])
    assert job_metric.job_id == IDS[4]
    assert job_metric.batch_id == IDS[3]
    assert job_metric.metric_url is not None
    assert "X-Amz-Signature" not in repr(job_metric)

    batch_metric = decode(BatchMetric, as_wire(ResimBatchMetric(**common)))
    assert batch_metric.batch_id == IDS[3]
    assert batch_metric.value == 12.5


def test_composite_metric_without_value() -> None:
    metric = decode(
        ApiMetric,
        {
            "metricID": str(IDS[0]),
            "name": "plot",
            "type": "COMPOSITE",
            "status": "RAW",
            "value": None,
        },
    )
    assert metric.value is None
    assert metric.metric_url is None
    assert metric.data_ids == ()
    assert metric.event_metric is False


def test_metrics_data_from_resim_json() -> None:
    common: dict[str, Any] = {
        "data_id": str(IDS[0]),
        "name": "speeds",
        "metrics_data_type": ResimMetricsDataType.STANDARD,
        "metrics_data_url": "https://storage.example.com/d?sig=1",
        "filename": "speeds.binproto",
        "creation_timestamp": NOW,
    }
    job_data = decode(ApiMetricsData, as_wire(ResimJobMetricsData(**common, job_id=str(IDS[1]))))
    assert job_data.is_standard
    assert job_data.job_id == IDS[1]
    assert job_data.filename == "speeds.binproto"
    assert "sig=1" not in repr(job_data)

    video = decode(
        BatchMetricsData,
        as_wire(
            ResimBatchMetricsData(
                **(common | {"metrics_data_type": ResimMetricsDataType.VIDEO}),
                batch_id=str(IDS[2]),
            )
        ),
    )
    assert not video.is_standard
    assert video.batch_id == IDS[2]


def test_batch_from_resim_json() -> None:
    wire = as_wire(
        ResimBatch(
            associated_account="acme",
            batch_id=str(IDS[0]),
            build_id=str(IDS[1]),
            branch_id=str(IDS[2]),
            test_suite_id=str(IDS[3]),
            test_suite_revision=4,
            total_jobs=120,
            friendly_name="brave-otter",
            status=ResimBatchStatus.BATCH_METRICS_RUNNING,
            conflated_status=ResimConflatedBatchStatus.RUNNING,
            batch_metrics_status=ResimMetricStatus.NO_STATUS_REPORTED,
            jobs_metrics_status=ResimMetricStatus.FAIL_BLOCK,
            creation_timestamp=NOW,
        )
    )
    batch = decode(Batch, wire)
    assert batch.batch_id == IDS[0]
    assert batch.status == BatchStatus.BATCH_METRICS_RUNNING
    assert batch.conflated_status == ConflatedBatchStatus.RUNNING
    assert batch.batch_metrics_status == ApiMetricStatus.NO_STATUS_REPORTED
    assert batch.jobs_metrics_status == ApiMetricStatus.FAIL_BLOCK
    assert batch.test_suite_revision == 4
    assert batch.total_jobs == 120
    assert batch.friendly_name == "brave-otter"
    assert batch.creation_timestamp == NOW


def test_report_from_resim_json() -> None:
    wire = as_wire(
        ResimReport(
            report_id=str(IDS[0]),
            project_id=str(IDS[1]),
            test_suite_id=str(IDS[2]),
            test_suite_revision=7,
            respect_revision_boundary=True,
            branch_id=str(IDS[3]),
            metrics_build_id=str(IDS[4]),
            metrics_set_name=None,
            start_timestamp=NOW - timedelta(days=7),
            end_timestamp=NOW,
            name="weekly",
            output_location="s3://bucket/report",
            status=ResimReportStatus.RUNNING,
            status_history=[],
            last_updated_timestamp=NOW,
            creation_timestamp=NOW,
            user_id="u",
            org_id="o",
            associated_account="acme",
            metrics_status=ResimMetricStatus.RAW,
        )
    )
    report = decode(Report, wire)
    assert report == Report(
        report_id=IDS[0],
        project_id=IDS[1],
        test_suite_id=IDS[2],
        test_suite_revision=7,
        branch_id=IDS[3],
        start_timestamp=NOW - timedelta(days=7),
        end_timestamp=NOW,
        respect_revision_boundary=True,
        name="weekly",
        creation_timestamp=NOW,
    )


def test_build_from_resim_json() -> None:
    wire = as_wire(
        ResimBuild(
            build_id=str(IDS[0]),
            branch_id=str(IDS[1]),
            project_id=str(IDS[2]),
            system_id=str(IDS[3]),
            description="abc123",
            version="1.2.3",
            image_uri="registry/image:tag",
            build_specification="",
            creation_timestamp=NOW,
            update_timestamp=NOW,
            associated_account="acme",
            user_id="u",
            update_user_id="u",
            org_id="o",
            name="nightly",
        )
    )
    assert decode(Build, wire) == Build(
        build_id=IDS[0], name="nightly", version="1.2.3", creation_timestamp=NOW
    )


def test_batch_metrics_set_name_is_read_and_null_or_empty_is_none() -> None:
    wire = {"batchID": str(IDS[0])}
    assert decode(Batch, wire).metrics_set_name is None
    for absent in (None, ""):
        assert decode(Batch, {**wire, "metricsSetName": absent}).metrics_set_name is None
    assert decode(Batch, {**wire, "metricsSetName": "nightly"}).metrics_set_name == "nightly"


def test_experience_from_resim_json() -> None:
    wire = as_wire(
        ResimExperience(
            experience_id=str(IDS[0]),
            project_id=str(IDS[1]),
            name="left turn",
            description="a left turn at dusk",
            location="s3://bucket/e",
            locations=["s3://bucket/e"],
            container_timeout_seconds=3600,
            profile="",
            environment_variables=[],
            creation_timestamp=NOW,
            update_timestamp=NOW,
            update_user_id="u",
            user_id="u",
            org_id="o",
            archived=False,
            cache_exempt=False,
            custom_fields=[
                ResimCustomField("Lighting", ["dusk"], ResimCustomFieldType.TEXT),
                ResimCustomField("Sensors", ["lidar", "camera"], ResimCustomFieldType.TEXT),
                ResimCustomField("Speed limit", ["30"], ResimCustomFieldType.NUMBER),
            ],
        )
    )
    experience = decode(Experience, wire)
    assert experience == Experience(
        experience_id=IDS[0],
        name="left turn",
        description="a left turn at dusk",
        custom_fields=(
            CustomField("Lighting", ("dusk",), "text"),
            CustomField("Sensors", ("lidar", "camera"), "text"),
            CustomField("Speed limit", ("30",), "number"),
        ),
        creation_timestamp=NOW,
    )
    assert experience.fields[1].texts == ("lidar", "camera")


@pytest.mark.parametrize(
    ("custom_fields", "read"),
    [
        ({}, ()),  # left out (a listing without includeCustomFields)
        ({"customFields": None}, ()),  # a Go client's nil list
        ({"customFields": []}, ()),
        (
            {"customFields": [{"name": "k", "values": None, "type": "text"}]},
            (CustomField("k", None, "text"),),
        ),
        ({"customFields": [{"name": "k"}]}, (CustomField("k"),)),
        (
            {"customFields": [{"name": "Where", "values": ["52.1,4.3"], "type": "geopoint"}]},
            (CustomField("Where", ("52.1,4.3",), "geopoint"),),  # a type not listed yet
        ),
        ({"customFields": [{"values": ["x"], "type": ""}]}, (CustomField("", ("x",)),)),
    ],
)
def test_experience_custom_fields_the_spec_allows_are_read(
    custom_fields: dict[str, Any], read: tuple[CustomField, ...]
) -> None:
    experience = decode(Experience, {"experienceID": str(IDS[0]), **custom_fields})
    assert experience.fields == read
    assert all(isinstance(f.texts, tuple) for f in experience.fields)


def test_timestamps_with_nanoseconds_and_offsets() -> None:
    job = decode(
        Job,
        {
            "jobID": str(IDS[0]),
            "conflatedStatus": "PASSED",
            "creationTimestamp": "2025-03-04T05:06:07.891011123+02:00",
        },
    )
    assert job.creation_timestamp == datetime(
        2025, 3, 4, 5, 6, 7, 891011, tzinfo=timezone(timedelta(hours=2))
    )


@pytest.mark.parametrize(
    "text",
    [
        "2026-01-02T03:04:05.123456789Z",  # Go's RFC3339Nano
        "2026-01-02t03:04:05.123456789z",  # RFC 3339 allows lower case
        "2026-01-02 03:04:05.1234567891234Z",
        "2026-01-02T05:04:05.123456789+02:00",
    ],
)
def test_rfc3339_timestamps_of_any_precision_and_case(text: str) -> None:
    job = decode(
        Job, {"jobID": str(IDS[0]), "conflatedStatus": "PASSED", "creationTimestamp": text}
    )
    assert job.creation_timestamp == datetime(2026, 1, 2, 3, 4, 5, 123456, tzinfo=UTC)


def test_absent_optional_fields_have_their_documented_meaning() -> None:
    """The spec's job, metric and metricsData schemas require nothing: absent is not an error."""
    job = decode(Job, {"jobID": str(IDS[0])})
    assert job.conflated_status is None  # counted as UNKNOWN by the aggregations
    metric = decode(ApiMetric, {"metricID": str(IDS[1])})
    assert metric.name == ""
    assert metric.type is None
    assert metric.status == ApiMetricStatus.NO_STATUS_REPORTED
    assert (metric.value, metric.unit, metric.metric_url) == (None, None, None)
    assert (metric.data_ids, metric.event_metric) == ((), False)
    data = decode(ApiMetricsData, {"dataID": str(IDS[2])})
    assert data.name == ""
    assert data.metrics_data_type == MetricsDataStorageType.STANDARD
    assert data.is_standard
    batch_metric = decode(BatchMetric, {"metricID": str(IDS[1]), "name": "", "status": ""})
    assert batch_metric.name == ""
    assert batch_metric.status == ApiMetricStatus.NO_STATUS_REPORTED
    assert decode(BatchMetricsData, {"dataID": str(IDS[2]), "name": ""}).name == ""


def test_unknown_enum_values_are_kept_by_name() -> None:
    """A value the platform adds later is kept as its raw string, never an error."""
    job = decode(
        Job,
        {
            "jobID": str(IDS[0]),
            "conflatedStatus": "FLAKY",
            "jobStatus": "RETRYING",
            "jobMetricsStatus": "FAIL_SOFT",
        },
    )
    assert (job.conflated_status, job.job_status, job.job_metrics_status) == (
        "FLAKY",
        "RETRYING",
        "FAIL_SOFT",
    )
    assert not isinstance(job.conflated_status, ConflatedJobStatus)
    metric = decode(
        ApiMetric,
        {"metricID": str(IDS[1]), "name": "m", "type": "HISTOGRAM", "status": "FAIL_SOFT"},
    )
    assert (metric.type, metric.status) == ("HISTOGRAM", "FAIL_SOFT")
    assert metric.type != ApiMetricType.SCALAR
    data = decode(
        ApiMetricsData, {"dataID": str(IDS[2]), "name": "lidar", "metricsDataType": "POINT_CLOUD"}
    )
    assert data.metrics_data_type == "POINT_CLOUD"
    assert not data.is_standard  # not a MetricsData message: never downloaded
    batch = decode(
        Batch, {"batchID": str(IDS[3]), "status": "ARCHIVED", "conflatedStatus": "ARCHIVED"}
    )
    assert (batch.status, batch.conflated_status) == ("ARCHIVED", "ARCHIVED")
    # Known values equal their members (StrEnums are strings).
    known = decode(ApiMetric, {"metricID": str(IDS[1]), "type": "SCALAR", "status": "RAW"})
    assert (known.type, known.status) == (ApiMetricType.SCALAR, ApiMetricStatus.RAW)


def test_empty_strings_read_as_absent() -> None:
    """The platform's Go encoder writes "" for an unset string as often as it omits it."""
    job = decode(
        Job,
        {"jobID": str(IDS[0]), "conflatedStatus": "", "jobStatus": "", "experienceName": ""},
    )
    assert (job.conflated_status, job.job_status, job.experience_name) == (None, None, None)
    metric = decode(
        ApiMetric,
        {"metricID": str(IDS[1]), "type": "", "status": "", "unit": "", "metricURL": ""},
    )
    assert (metric.type, metric.status, metric.unit, metric.metric_url) == (
        None,
        ApiMetricStatus.NO_STATUS_REPORTED,
        None,
        None,
    )
    data = decode(
        ApiMetricsData,
        {"dataID": str(IDS[2]), "metricsDataType": "", "metricsDataURL": "", "filename": ""},
    )
    assert (data.metrics_data_type, data.metrics_data_url, data.filename) == (
        MetricsDataStorageType.STANDARD,
        None,
        None,
    )
    assert data.is_standard


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ({"jobID": "1234", "conflatedStatus": "PASSED"}, "Invalid UUID - at `$.jobID`"),
        ({"jobID": "", "conflatedStatus": "PASSED"}, "Invalid UUID - at `$.jobID`"),
        ({"jobID": str(IDS[0]), "buildID": ""}, "Invalid UUID - at `$.buildID`"),
        ({"conflatedStatus": "PASSED"}, "Object missing required field `jobID`"),
        (
            {"jobID": str(IDS[0]), "conflatedStatus": 3},
            "Expected `str | null`, got `int` - at `$.conflatedStatus`",
        ),
        (
            {"jobID": str(IDS[0]), "creationTimestamp": "yesterday"},
            "Not an RFC 3339 timestamp: 'yesterday' - at `$.creationTimestamp`",
        ),
        (
            {"jobID": str(IDS[0]), "creationTimestamp": "2025-01-01T00:00:00"},
            "An RFC 3339 timestamp without a time zone: '2025-01-01T00:00:00'"
            " - at `$.creationTimestamp`",
        ),
        (
            {"jobID": str(IDS[0]), "creationTimestamp": 1700000000},
            "Expected an RFC 3339 timestamp, got int - at `$.creationTimestamp`",
        ),
        (
            {"jobID": str(IDS[0]), "parameters": {"speed": 3}},
            "Expected `str`, got `int` - at `$.parameters[...]`",
        ),
        (["not", "an", "object"], "Expected `object`, got `array`"),
    ],
)
def test_job_errors_name_the_field_by_its_path(data: Any, message: str) -> None:
    with pytest.raises(msgspec.ValidationError) as caught:
        decode(Job, data)
    assert str(caught.value) == message


@pytest.mark.parametrize(
    ("field", "value", "problem"),
    [
        ("value", True, "Expected `float | null`, got `bool`"),
        ("value", 10**400, "Number out of range"),
        ("value", "many", "Expected `float | null`, got `str`"),
        ("dataIDs", ["nope"], "Invalid UUID"),
        ("dataIDs", "nope", "Expected `array`, got `str`"),
        ("eventMetric", "yes", "Expected `bool`, got `str`"),
        ("status", 3, "Expected `str`, got `int`"),
        ("name", None, "Expected `str`, got `null`"),
    ],
)
def test_metric_field_errors(field: str, value: Any, problem: str) -> None:
    data = {"metricID": str(IDS[0]), "name": "m", "type": "SCALAR", "status": "PASSED"}
    with pytest.raises(msgspec.ValidationError) as caught:
        decode(BatchMetric, data | {field: value})
    assert str(caught.value).startswith(f"{problem} - at `$.{field}")


def test_lax_mode_reads_what_a_json_encoder_may_write_for_a_number() -> None:
    """Integral floats for integers; numbers and booleans written as strings."""
    metric = decode(ApiMetric, {"metricID": str(IDS[0]), "value": "1.5", "eventMetric": "true"})
    assert (metric.value, metric.event_metric) == (1.5, True)
    assert decode(ApiMetric, {"metricID": str(IDS[0]), "value": 2**64 + 1}).value == 2.0**64


def test_report_requires_its_search_window() -> None:
    data = {
        "reportID": str(IDS[0]),
        "projectID": str(IDS[1]),
        "testSuiteID": str(IDS[2]),
        "testSuiteRevision": 1,
        "branchID": str(IDS[3]),
        "startTimestamp": "2025-01-01T00:00:00Z",
    }
    with pytest.raises(msgspec.ValidationError, match="missing required field `endTimestamp`"):
        decode(Report, data)


def test_integer_fields_accept_integral_floats_only() -> None:
    batch = decode(Batch, {"batchID": str(IDS[0]), "totalJobs": 3.0})
    assert batch.total_jobs == 3
    with pytest.raises(msgspec.ValidationError, match=r"got `float` - at `\$.totalJobs`"):
        decode(Batch, {"batchID": str(IDS[0]), "totalJobs": 3.5})


def test_models_are_frozen_and_slotted() -> None:
    job = Job(job_id=IDS[0], conflated_status=ConflatedJobStatus.PASSED)
    with pytest.raises(AttributeError):
        job.job_id = IDS[1]  # type: ignore[misc]
    assert not hasattr(job, "__dict__")
    # A job's parameters (a dict) do not keep it from being hashed, by its ID.
    assert hash(job) == hash(Job(job_id=IDS[0], conflated_status=None, parameters={"a": "b"}))


def test_a_batch_listings_items_say_their_owner() -> None:
    metric = {"metricID": str(IDS[0]), "jobID": str(IDS[1]), "batchID": str(IDS[2])}
    of_job = decode(ApiMetric, metric)
    of_batch = decode(BatchMetric, metric)
    assert (of_job.owner, of_batch.owner) == (MetricOwner.JOB, MetricOwner.BATCH)
    assert isinstance(of_batch, ApiMetric)
    data = {"dataID": str(IDS[3]), "batchID": str(IDS[2])}
    job_data, batch_data = decode(ApiMetricsData, data), decode(BatchMetricsData, data)
    assert (job_data.owner, batch_data.owner) == (MetricOwner.JOB, MetricOwner.BATCH)
    assert batch_data.batch_id == IDS[2]
    # The owner is not read from the answer: a key of that name changes nothing.
    assert decode(ApiMetric, metric | {"owner": "batch"}).owner is MetricOwner.JOB


def test_presigned_urls_stay_out_of_repr() -> None:
    metric = decode(ApiMetric, {"metricID": str(IDS[0]), "metricURL": "https://s/m?sig=SECRET"})
    data = decode(ApiMetricsData, {"dataID": str(IDS[1]), "metricsDataURL": "https://s?sig=SECRET"})
    log = decode(JobLog, {"logID": str(IDS[2]), "logOutputLocation": "https://s?sig=SECRET"})
    for item in (metric, data, log):
        assert "SECRET" not in repr(item)
        assert str(IDS[0]) in repr(metric)


@pytest.mark.parametrize(
    ("text", "moment"),
    [
        # RFC 3339 allows a leap second; it is read as the last instant before it.
        ("2016-12-31T23:59:60Z", datetime(2016, 12, 31, 23, 59, 59, 999_999, tzinfo=UTC)),
        ("2016-12-31T23:59:60.5Z", datetime(2016, 12, 31, 23, 59, 59, 999_999, tzinfo=UTC)),
        ("2016-12-31t23:59:60z", datetime(2016, 12, 31, 23, 59, 59, 999_999, tzinfo=UTC)),
    ],
)
def test_a_leap_second_is_read_not_refused(text: str, moment: datetime) -> None:
    assert parse_rfc3339(text) == moment
    job = decode(Job, {"jobID": str(IDS[0]), "creationTimestamp": text})
    assert job.creation_timestamp == moment
    assert isinstance(job.creation_timestamp, Timestamp)


@pytest.mark.parametrize("text", ["2016-12-31T23:59:61Z", "2016-12-31T23:60:00Z"])
def test_past_a_leap_second_is_no_time(text: str) -> None:
    assert parse_rfc3339(text) is None
    with pytest.raises(msgspec.ValidationError, match="Not an RFC 3339 timestamp"):
        decode(Job, {"jobID": str(IDS[0]), "creationTimestamp": text})


@pytest.mark.parametrize("text", [str(IDS[0]), str(IDS[0]).upper(), str(IDS[0]).replace("-", "")])
def test_an_id_reads_in_the_forms_the_api_writes(text: str) -> None:
    assert decode(Job, {"jobID": text}).job_id == IDS[0]
