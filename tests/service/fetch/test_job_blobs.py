"""One job's blobs, events, tags and parameters as the plan asks for them, against a real
HTTP server scripted with the API's answers and real protobuf bytes (a MetricsWriter's)."""

from __future__ import annotations

import asyncio
import uuid
from collections.abc import Sequence
from dataclasses import dataclass, field
from datetime import UTC, datetime
from typing import Any, cast

import pytest

from stook.proto import metrics_pb2 as pb
from stook.sdk import MetricsWriter, MetricType, SeriesKind, data, parse_metric
from stook.sdk.aggregations import JobEvent, JobRecord, Needs, Scalar
from stook.service.api import RetryPolicy
from stook.service.api._client import ApiClient
from stook.service.fetch import BatchFetcher, InvalidDataError, decode_values
from tests.service.scripted_server import ScriptedServer, answer, answer_json

PROJECT = uuid.UUID("00000000-0000-4000-8000-000000000001")
BATCH = uuid.UUID("00000000-0000-4000-8000-000000000002")
EXPERIENCE = uuid.UUID("00000000-0000-4000-8000-000000000003")
OTHER_EXPERIENCE = uuid.UUID("00000000-0000-4000-8000-000000000004")
BASE = f"/v1/projects/{PROJECT}/batches/{BATCH}"


def _job_output(job_id: uuid.UUID) -> pb.JobMetrics:
    writer = MetricsWriter(job_id, deterministic=True)
    times = data.timestamps("timestamps", [1_000, 2_000, 3_000])
    offsets = data.doubles("offsets", [0.1, 0.2, 0.3], unit="m", index=times)
    writer.double_over_time("Offset over time", offsets)
    writer.histogram(
        "Speed histogram", data.doubles("speeds", [1.0, 2.0, 5.0]), buckets=4, lower=0, upper=8
    )
    where = data.per_category(
        "where", SeriesKind.STRING, {"car": ["left", "right"], "truck": ["left"]}
    )
    per_class = data.per_category(
        "detections per class", SeriesKind.DOUBLE, {"car": [3.0, 4.0], "truck": [1.0]}, index=where
    )
    writer.bar_chart("Detections", per_class)
    writer.scalar("Max speed", 5.0, unit="m/s")
    writer.add_data(data.strings("labels", ["a", "b"]))
    return writer.to_proto()


@dataclass
class ScriptedBatch:
    """One batch on a ScriptedServer: each job's listings and blobs, as the API serves them."""

    server: ScriptedServer
    jobs: list[dict[str, Any]] = field(default_factory=list)

    def add_job(
        self,
        output: pb.JobMetrics | None = None,
        *,
        experience: uuid.UUID = EXPERIENCE,
        parameters: dict[str, str] | None = None,
        events: Sequence[dict[str, Any]] = (),
        metric_overrides: dict[str, dict[str, Any]] | None = None,
        blob_overrides: dict[str, bytes] | None = None,
        data_overrides: dict[str, dict[str, Any]] | None = None,
    ) -> uuid.UUID:
        job_id = uuid.UUID(output.job_id.id.data) if output is not None else uuid.uuid4()
        output = output if output is not None else _job_output(job_id)
        job: dict[str, Any] = {
            "jobID": str(job_id),
            "experienceID": str(experience),
            "experienceName": f"exp {experience.hex[-1]}",
            "conflatedStatus": "PASSED",
        }
        if parameters is not None:
            job["parameters"] = parameters
        self.jobs.append(job)
        metrics, listed_data = [], []
        for m in output.job_level_metrics.metrics:
            body = m.SerializeToString()
            item: dict[str, Any] = {
                "metricID": m.metric_id.id.data,
                "name": m.name,
                "type": "SCALAR" if m.type == pb.SCALAR_METRIC_TYPE else "COMPOSITE",
                "status": "PASSED",
                "metricURL": self.server.url(f"/blob/{m.metric_id.id.data}"),
            }
            if m.type == pb.SCALAR_METRIC_TYPE:
                item["value"] = m.metric_values.scalar_metric_values.value
            item |= (metric_overrides or {}).get(m.name, {})
            body = (blob_overrides or {}).get(m.name, body)
            metrics.append(item)
            self.server.script(f"/blob/{m.metric_id.id.data}", answer(body=body))
        for d in output.metrics_data:
            data_item: dict[str, Any] = {
                "dataID": d.metrics_data_id.id.data,
                "name": d.name,
                "metricsDataURL": self.server.url(f"/blob/{d.metrics_data_id.id.data}"),
            }
            listed_data.append(data_item | (data_overrides or {}).get(d.name, {}))
            self.server.script(
                f"/blob/{d.metrics_data_id.id.data}", answer(body=d.SerializeToString())
            )
        self.server.script(f"{BASE}/jobs/{job_id}/metrics", answer_json({"metrics": metrics}))
        self.server.script(
            f"{BASE}/jobs/{job_id}/metricsData", answer_json({"metricsData": listed_data})
        )
        self.server.script(f"{BASE}/jobs/{job_id}/events", answer_json({"events": list(events)}))
        self.server.script(f"{BASE}/jobs", answer_json({"jobs": self.jobs}))
        return job_id

    def tags(self, experience: uuid.UUID, *names: str) -> None:
        self.server.script(
            f"/v1/projects/{PROJECT}/experiences/{experience}/experienceTags",
            answer_json(
                {
                    "experienceTags": [
                        {"experienceTagID": str(uuid.uuid4()), "name": n} for n in names
                    ]
                }
            ),
        )

    def blob_paths(self) -> list[str]:
        return [seen.path for seen in self.server.seen if seen.path.startswith("/blob/")]

    def api_paths(self, suffix: str) -> list[str]:
        return [seen.path for seen in self.server.seen if seen.path.endswith(suffix)]


@pytest.fixture
def batch(server: ScriptedServer) -> ScriptedBatch:
    return ScriptedBatch(server)


async def _fetch(
    server: ScriptedServer, policy: RetryPolicy, needs: Needs, workers: int = 4
) -> list[JobRecord]:
    records: list[JobRecord] = []
    async with ApiClient(server.base_url, "secret-token", retry=policy) as api:
        await BatchFetcher(api, PROJECT, BATCH, needs, workers=workers).run(records.append)
    return records


async def test_a_metric_listing_gives_scalars_statuses_and_names(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    batch.add_job()
    batch.add_job(metric_overrides={"Max speed": {"status": "FAIL_WARN", "unit": "m/s"}})
    batch.add_job(metric_overrides={"Max speed": {"eventMetric": True, "status": ""}})
    batch.add_job(metric_overrides={"Offset over time": {"name": "", "status": "NEW_ONE"}})
    needs = Needs(data=frozenset({"speeds"}), every_scalar=True)
    records: list[JobRecord] = []
    async with ApiClient(server.base_url, "secret-token", retry=fast_policy) as api:
        fetcher = BatchFetcher(api, PROJECT, BATCH, needs, workers=2)
        outcome = await fetcher.run(records.append)
    assert len(records) == 4
    for record in records:
        assert [type(s) for s in record.scalars.values()] == [Scalar] * len(record.scalars)
        assert list(record.data) == ["speeds"]
    assert outcome.jobs_with_metrics == 4
    assert outcome.scalar_names == {"Max speed"}
    assert "Offset over time" in outcome.metric_names
    assert sum(bool(r.scalars) for r in records) == 3  # all but the event's job
    statuses = sorted(s for r in records for s in r.metric_statuses)
    assert "NEW_ONE" in statuses
    assert "NO_STATUS_REPORTED" in statuses  # the event's "" status
    assert "FAIL_WARN" in statuses


async def test_a_data_listing_gives_the_wanted_standard_data_by_name(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    batch.add_job()
    batch.add_job(data_overrides={"labels": {"name": ""}, "offsets": {"filename": None}})
    batch.add_job(data_overrides={"speeds": {"metricsDataType": "VIDEO"}})
    batch.add_job(data_overrides={"where": {"creationTimestamp": "2025-01-18t14:03:00z"}})
    needs = Needs(data=frozenset({"speeds", "labels", "where"}), every_scalar=True)
    records: list[JobRecord] = []
    async with ApiClient(server.base_url, "secret-token", retry=fast_policy) as api:
        fetcher = BatchFetcher(api, PROJECT, BATCH, needs, workers=2)
        outcome = await fetcher.run(records.append)
    # Unnamed data cannot be asked for; a video is no MetricsData message.
    assert sorted(sorted(r.data) for r in records) == sorted(
        [["labels", "speeds", "where"]] * 2 + [["speeds", "where"]] + [["labels", "where"]]
    )
    assert outcome.unnamed_data == 1
    assert outcome.missing == []
    assert "speeds" in outcome.data_names


async def test_a_malformed_data_listing_fails_its_job_as_the_model_words_it(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    batch.add_job()
    bad = batch.add_job(data_overrides={"timestamps": {"jobID": "not an ID"}})
    needs = Needs(data=frozenset({"speeds"}))
    records: list[JobRecord] = []
    async with ApiClient(server.base_url, "secret-token", retry=fast_policy) as api:
        fetcher = BatchFetcher(api, PROJECT, BATCH, needs, workers=2)
        outcome = await fetcher.run(records.append)
    assert len(records) == 1
    (missing,) = outcome.missing
    assert missing.job_id == bad
    assert "unusable answer: Invalid UUID - at `$.metricsData[0].jobID`" in missing.reason


def _ids(output: pb.JobMetrics, *names: str) -> set[str]:
    return {d.metrics_data_id.id.data for d in output.metrics_data if d.name in names}


async def test_a_plan_without_blobs_downloads_none(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    batch.add_job(parameters={"max_speed": "10"})
    (record,) = await _fetch(server, fast_policy, Needs())
    assert batch.blob_paths() == []
    assert batch.api_paths("/metricsData") == batch.api_paths("/events") == []
    assert record.scalars["Max speed"].value == 5.0
    assert record.parameters == {"max_speed": "10"}  # from the job listing, free
    assert record.job_metrics is None
    assert record.data == {}
    assert record.events == ()


async def test_a_job_without_parameters_has_none(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    batch.add_job()
    (record,) = await _fetch(server, fast_policy, Needs())
    assert record.parameters == {}


async def test_data_of_any_kind_keeps_its_kind_index_and_categories(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    job_id = uuid.uuid4()
    output = _job_output(job_id)
    batch.add_job(output)
    names = {"offsets", "labels", "detections per class"}
    (record,) = await _fetch(server, fast_policy, Needs(data=frozenset(names)))
    assert set(record.data) == names
    per_class = record.data["detections per class"]
    assert per_class.per_category
    assert per_class.categories == ("car", "truck")
    assert per_class.category_series("car").to_list() == [3.0, 4.0]
    assert record.data["labels"].kind is SeriesKind.STRING
    assert record.data["offsets"].index_id is not None
    # A series only for plain doubles: no categories flattened away, no strings.
    assert list(record.series) == ["offsets"]
    assert record.series["offsets"].to_list() == [0.1, 0.2, 0.3]
    # Exactly the three named: the offsets' index is not downloaded for data asked by name.
    assert sorted(batch.blob_paths()) == sorted(f"/blob/{i}" for i in _ids(output, *names))


async def test_data_with_index_comes_with_its_index_attached(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    job_id = uuid.uuid4()
    output = _job_output(job_id)
    batch.add_job(output)
    wanted = frozenset({"offsets"})
    (record,) = await _fetch(server, fast_policy, Needs(data=wanted, data_with_index=wanted))
    offsets = record.data["offsets"]
    assert offsets.index is not None
    assert offsets.index.id == offsets.index_id
    assert offsets.index.kind is SeriesKind.TIMESTAMP
    assert record.series["offsets"].to_list() == [0.1, 0.2, 0.3]
    # The data and its index: one more download than the data alone, nothing else.
    index_name = offsets.index.name
    expected = {f"/blob/{i}" for i in _ids(output, "offsets", index_name)}
    assert sorted(batch.blob_paths()) == sorted(expected)
    assert len(expected) == 2


async def test_a_named_metric_costs_its_blob_and_its_data_with_their_index(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    job_id = uuid.uuid4()
    output = _job_output(job_id)
    batch.add_job(output)
    needs = Needs(metrics=frozenset({"Offset over time"}), data=frozenset({"offsets"}))
    (record,) = await _fetch(server, fast_policy, needs)
    view = record.job_metrics
    assert view is not None
    assert view.job_id == job_id
    (metric,) = view.metrics
    assert metric.name == "Offset over time"
    assert metric.type is MetricType.DOUBLE_OVER_TIME
    offsets = view.data_by_name["offsets"]
    assert offsets.index_id is not None
    assert offsets.index_id in view.data_by_id  # the index came with it
    assert view.data_by_id[offsets.index_id].kind is SeriesKind.TIMESTAMP
    (over_time,) = (m for m in output.job_level_metrics.metrics if m.name == "Offset over time")
    # The metric, its values and statuses, and their index; nothing of the other metrics.
    referenced = {str(i) for i in parse_metric(over_time).data_ids}
    assert len(referenced) == 2
    wanted = {over_time.metric_id.id.data} | referenced | _ids(output, "timestamps")
    assert {d.id for d in view.data} == {uuid.UUID(i) for i in wanted - {str(metric.id)}}
    # Shared between `data` and the metric, the offsets are downloaded once.
    assert sorted(batch.blob_paths()) == sorted(f"/blob/{i}" for i in wanted)


async def test_every_metric_is_the_whole_job(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    job_id = uuid.uuid4()
    output = _job_output(job_id)
    batch.add_job(output)
    (record,) = await _fetch(server, fast_policy, Needs(every_metric=True))
    view = record.job_metrics
    assert view is not None
    assert [m.name for m in view.metrics] == [m.name for m in output.job_level_metrics.metrics]
    assert sorted(d.name for d in view.data) == sorted(d.name for d in output.metrics_data)
    detections = next(m for m in view.metrics if m.name == "Detections")
    bars = view.data_by_id[detections.data_ids[0]]
    assert bars.categories == ("car", "truck")
    assert len(batch.blob_paths()) == len(output.job_level_metrics.metrics) + len(
        output.metrics_data
    )


async def test_a_wanted_metric_that_is_not_a_metric_is_invalid_data(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    job_id = batch.add_job(blob_overrides={"Speed histogram": b"\xff\xff\xff not protobuf"})
    with pytest.raises(InvalidDataError, match=f"job {job_id} / metric 'Speed histogram'"):
        await _fetch(server, fast_policy, Needs(metrics=frozenset({"Speed histogram"})))


async def test_a_referenced_data_id_the_job_lacks_is_invalid_data(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    ghost = uuid.uuid4()
    job_id = batch.add_job(metric_overrides={"Speed histogram": {"dataIDs": [str(ghost)]}})
    with pytest.raises(InvalidDataError) as raised:
        await _fetch(server, fast_policy, Needs(metrics=frozenset({"Speed histogram"})))
    message = str(raised.value)
    assert f"job {job_id}" in message
    assert "'Speed histogram'" in message
    assert str(ghost) in message
    assert "secret-token" not in message


async def test_events_are_listed_per_job_in_the_api_spelling(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    event_id, metric_id = uuid.uuid4(), uuid.uuid4()
    batch.add_job(
        events=[
            {
                "eventID": str(event_id),
                "name": "Hard brake",
                "description": "braked at 6 m/s^2",
                "creationTimestamp": "2026-01-02T03:04:05Z",
                "timestampType": "RELATIVE",
                "timestamp": "2026-01-02T03:04:06.5Z",
                "tags": ["safety"],
                "status": "FAIL_WARN",
                "metricsIDs": [str(metric_id)],
            },
            # Fields the spec requires may be absent; a status it lacks is kept.
            {"eventID": str(uuid.uuid4()), "status": "SOMETHING_NEW"},
        ]
    )
    (record,) = await _fetch(server, fast_policy, Needs(events=True))
    first, second = record.events
    assert first == JobEvent(
        event_id=event_id,
        name="Hard brake",
        status="FAIL_WARN",
        timestamp=datetime(2026, 1, 2, 3, 4, 6, 500_000, tzinfo=UTC),
        timestamp_type="RELATIVE",
        description="braked at 6 m/s^2",
        tags=("safety",),
        metric_ids=(metric_id,),
    )
    assert (second.name, second.status, second.timestamp, second.tags) == (
        "",
        "SOMETHING_NEW",
        None,
        (),
    )
    assert len(batch.api_paths("/events")) == 1


async def test_tags_are_listed_once_per_experience(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    for _ in range(6):
        batch.add_job(experience=EXPERIENCE)
    batch.add_job(experience=OTHER_EXPERIENCE)
    batch.tags(EXPERIENCE, "night", "highway", "")
    batch.tags(OTHER_EXPERIENCE)
    records = await _fetch(server, fast_policy, Needs(experience_tags=True), workers=8)
    tags = {r.experience_id: tuple(r.experience_tags) for r in records}
    assert tags == {EXPERIENCE: ("highway", "night"), OTHER_EXPERIENCE: ()}
    assert len(batch.api_paths("/experienceTags")) == 2


async def test_a_failed_tag_listing_fails_its_jobs_alike(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    for _ in range(3):
        batch.add_job(experience=EXPERIENCE)
    batch.tags(OTHER_EXPERIENCE)  # EXPERIENCE's tags are unscripted: 404
    records: list[JobRecord] = []
    async with ApiClient(server.base_url, "secret-token", retry=fast_policy) as api:
        fetcher = BatchFetcher(api, PROJECT, BATCH, Needs(experience_tags=True), workers=3)
        outcome = await fetcher.run(records.append)
    assert records == []
    assert len(outcome.missing) == 3
    assert len(batch.api_paths("/experienceTags")) == 1


def test_decode_values_refuses_per_category_data() -> None:
    where = data.per_category("where", SeriesKind.STRING, {"car": ["left"]})
    per_class = data.per_category("per class", SeriesKind.DOUBLE, {"car": [1.0]}, index=where)
    writer = MetricsWriter(uuid.uuid4(), deterministic=True)
    writer.bar_chart("Bars", per_class)
    msg = next(d for d in writer.to_proto().metrics_data if d.name == "per class")
    with pytest.raises(InvalidDataError, match="per category"):
        decode_values(msg.SerializeToString(), source="job 1")
    plain = data.doubles("plain", [1.0, 2.0])
    writer.add_data(plain)
    found = next(d for d in writer.to_proto().metrics_data if d.name == "plain")
    assert decode_values(found.SerializeToString(), source="job 1").to_list() == [1.0, 2.0]
    with pytest.raises(InvalidDataError):
        decode_values(b"\xff\xff", source="job 1")


async def test_a_fetch_leaves_the_garbage_collector_as_it_found_it(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    # A library call never retunes its process: only the console script collects less
    # (stook.service.cli._process).
    import gc

    batch.add_job()
    batch.add_job()
    before = gc.get_threshold(), gc.get_freeze_count()
    seen: list[tuple[tuple[int, int, int], int]] = []
    async with ApiClient(server.base_url, "secret-token", retry=fast_policy) as api:
        fetcher = BatchFetcher(api, PROJECT, BATCH, Needs(), workers=2)
        await fetcher.run(lambda record: seen.append((gc.get_threshold(), gc.get_freeze_count())))
    assert seen == [before, before]


class _ListingApi:
    """A job's metrics and metrics-data listings, each a few loop steps long; it counts
    the listings in flight at once, and can fail the metrics listing."""

    storage = None

    def __init__(self, *, metrics_fail: bool = False) -> None:
        self.metrics_fail = metrics_fail
        self.in_flight = 0
        self.most_in_flight = 0
        self.data_listings = 0

    async def _listing(self) -> None:
        self.in_flight += 1
        self.most_in_flight = max(self.most_in_flight, self.in_flight)
        try:
            for _ in range(3):
                await asyncio.sleep(0)
        finally:
            self.in_flight -= 1

    async def list_job_metrics(self, *_ids: object) -> list[Any]:
        from stook.service.api import ApiResponseError

        await self._listing()
        if self.metrics_fail:
            raise ApiResponseError("the metrics listing failed")
        return []

    async def list_job_metrics_data(self, *_ids: object) -> list[Any]:
        self.data_listings += 1
        await self._listing()
        return []


async def _fetch_listed_job(api: _ListingApi) -> list[str]:
    from stook.service.api import Job

    job = Job(uuid.uuid4())
    needs = Needs(data=frozenset({"speeds"}))
    fetcher = BatchFetcher(cast(ApiClient, api), PROJECT, BATCH, needs, workers=1, jobs=[job])
    outcome = await fetcher.run(lambda record: None)
    return [m.reason for m in outcome.missing]


async def test_a_jobs_listings_go_out_one_after_another() -> None:
    # One request in flight per worker: the workers are as many as the concurrency bound,
    # so listings side by side would only queue for a slot.
    api = _ListingApi()
    assert await _fetch_listed_job(api) == []
    assert api.data_listings == 1
    assert api.most_in_flight == 1


async def test_a_failed_metrics_listing_sends_no_other_listing() -> None:
    api = _ListingApi(metrics_fail=True)
    assert await _fetch_listed_job(api) == ["the metrics listing failed"]
    assert api.data_listings == 0


async def test_a_record_is_a_job_record_like_one_made_by_its_init(
    server: ScriptedServer, batch: ScriptedBatch, fast_policy: RetryPolicy
) -> None:
    import dataclasses

    batch.add_job(parameters={"max_speed": "10"})
    (record,) = await _fetch(server, fast_policy, Needs(data=frozenset({"speeds"})))
    assert type(record) is JobRecord
    made = dataclasses.replace(record)  # every field through JobRecord.__init__
    assert record == made
    assert repr(record) == repr(made)
    with pytest.raises(dataclasses.FrozenInstanceError):
        record.job_id = uuid.uuid4()  # type: ignore[misc]
