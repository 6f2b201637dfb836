"""The batch summary: its bytes round-trip, are deterministic, say their version, refuse
what they are not, and its writer folds jobs into metrics data ReSim's validator accepts."""

from __future__ import annotations

import dataclasses
import math
import struct
import uuid

import pytest
from hypothesis import given
from hypothesis import strategies as st
from resim.metrics.proto import metrics_pb2 as rp
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.sdk import MetricsWriter, data, read_job_metrics, read_metrics_data
from stook.sdk.aggregations import (
    SUMMARY_DATA_NAME,
    SUMMARY_VERSION,
    BatchSummary,
    BatchSummaryWriter,
    JobRecord,
    Scalar,
    SummaryError,
    SummaryJob,
    SummaryVersionError,
    decode_summary,
    encode_summary,
    summary_from_data,
)
from stook.sdk.aggregations._summary import summary_text
from stook.sdk.testing import check_merge_laws
from tests.hypothesis_profiles import examples


def _job(i: int, **changes: object) -> SummaryJob:
    job = SummaryJob(
        uuid.UUID(int=(i * 7919) % 1000 + 1),
        f"Experience {i % 3} é",
        ["PASSED", "ERROR", "WARNING"][i % 3],
        uuid.UUID(int=10_000 + i % 3) if i % 4 else None,
        bool(i % 5),
        {"Speed": (float(i) / 3, "m/s"), "Collisions": (float(i % 2), "")} if i % 5 else {},
    )
    return dataclasses.replace(job, **changes)  # type: ignore[arg-type]


def _summary(n: int) -> BatchSummary:
    jobs = sorted((_job(i) for i in range(n)), key=lambda j: j.job_id.bytes)
    return BatchSummary(tuple(jobs), {"FAIL_WARN": 2, "PASSED": 3 * n})


@pytest.mark.parametrize("n", [0, 1, 9, 300])
def test_round_trip(n: int) -> None:
    summary = _summary(n)
    assert decode_summary(encode_summary(summary)) == summary


def test_values_round_trip_bit_for_bit() -> None:
    odd = [-0.0, math.inf, -math.inf, 5e-324, 1.7976931348623157e308, 0.1 + 0.2]
    jobs = tuple(_job(i, scalars={"x": (v, "m")}) for i, v in enumerate(odd))
    decoded = decode_summary(encode_summary(BatchSummary(jobs)))
    got = [j.scalars["x"][0] for j in decoded.jobs]
    want = [j.scalars["x"][0] for j in sorted(jobs, key=lambda j: j.job_id.bytes)]
    assert [struct.pack("<d", v) for v in got] == [struct.pack("<d", v) for v in want]
    nan = decode_summary(encode_summary(BatchSummary((_job(1, scalars={"x": (math.nan, "")}),))))
    assert math.isnan(nan.jobs[0].scalars["x"][0])


def test_many_names_widen_the_indexes() -> None:
    jobs = tuple(_job(i, experience_name=f"experience {i}") for i in range(70_000 // 100))
    wide = tuple(j for j in jobs) + tuple(
        _job(i, job_id=uuid.UUID(int=10**6 + i), scalars={f"m{i}": (1.0, f"u{i}")})
        for i in range(300)
    )
    summary = BatchSummary(tuple(sorted(wide, key=lambda j: j.job_id.bytes)))
    payload = encode_summary(summary)
    assert payload[6] == 2  # more than 255 strings: two-byte indexes
    assert decode_summary(payload) == summary


def test_equal_batches_give_equal_bytes_whatever_the_job_order() -> None:
    summary = _summary(40)
    shuffled = BatchSummary(
        tuple(reversed(summary.jobs)), dict(reversed(list(summary.metric_statuses.items())))
    )
    assert encode_summary(shuffled) == encode_summary(summary)


def test_a_newer_version_is_refused_by_name() -> None:
    payload = bytearray(encode_summary(_summary(3)))
    payload[4:6] = struct.pack("<H", SUMMARY_VERSION + 1)
    with pytest.raises(SummaryVersionError, match=f"version {SUMMARY_VERSION + 1} is newer"):
        decode_summary(bytes(payload))


@pytest.mark.parametrize(
    ("mangle", "message"),
    [
        (lambda b: b"PK\x03\x04" + b[4:], "no STKS header"),
        (lambda b: b[:3], "no STKS header"),
        (lambda b: b[:4] + struct.pack("<H", 0) + b[6:], "version 0 does not exist"),
        (lambda b: b[:6] + b"\x03" + b[7:], "index width 3"),
        (lambda b: b[: len(b) // 2], "truncated"),
        (lambda b: b + b"\x00", "past its end"),
    ],
)
def test_bytes_that_are_no_summary_are_refused(mangle: object, message: str) -> None:
    payload = encode_summary(_summary(5))
    with pytest.raises(SummaryError, match=message):
        decode_summary(mangle(payload))  # type: ignore[operator]


def _records(n: int) -> list[JobRecord]:
    return [
        JobRecord(
            uuid.UUID(int=i + 1),
            ["PASSED", "BLOCKER"][i % 2],
            experience_name=f"E{i % 3}",
            experience_id=uuid.UUID(int=100 + i % 3),
            scalars={"a": Scalar(i / 7, "m", "PASSED")} if i % 3 else {},
            metric_statuses=["PASSED", "FAIL_WARN"][: i % 3],
        )
        for i in range(n)
    ]


def test_the_writer_writes_metrics_data_resims_validator_accepts() -> None:
    writer = MetricsWriter(uuid.UUID(int=5), deterministic=True)
    writer.scalar("Failed tests", 1.0)
    summary = BatchSummaryWriter()
    for record in _records(8):
        summary.update(record)
    summary.finish(writer)
    payload = writer.to_proto().SerializeToString(deterministic=True)
    msg = rp.JobMetrics()
    msg.ParseFromString(payload)
    resim_validate(msg)
    view = read_job_metrics(payload)
    (found,) = [d for d in view.data if d.name == SUMMARY_DATA_NAME]
    got = summary_from_data(found)
    assert len(got.jobs) == 8
    assert got.metric_statuses == {"FAIL_WARN": 2, "PASSED": 5}
    by_id = {j.job_id: j for j in got.jobs}
    assert by_id[uuid.UUID(int=2)].scalars == {"a": (1 / 7, "m")}
    assert by_id[uuid.UUID(int=1)].has_metrics is False
    assert by_id[uuid.UUID(int=2)].experience_id == uuid.UUID(int=101)


def test_a_skipped_summary_writes_nothing() -> None:
    writer = MetricsWriter(uuid.UUID(int=5), deterministic=True)
    writer.scalar("Failed tests", 1.0)
    summary = BatchSummaryWriter()
    summary.update(_records(1)[0])
    summary.skip("1 job's metrics could not be read")
    summary.finish(writer)
    assert not writer.to_proto().metrics_data


def test_the_writer_reads_every_scalar() -> None:
    needs = BatchSummaryWriter().needs()
    assert needs.every_scalar
    assert needs.wants_scalar("any name at all")


def test_the_writer_obeys_the_merge_laws() -> None:
    check_merge_laws(BatchSummaryWriter, _records(9), rounds=4)


def test_data_that_holds_no_summary_is_refused() -> None:
    for item in (data.strings(SUMMARY_DATA_NAME, ["a", "b"]), data.doubles("x", [1.0])):
        writer = MetricsWriter(uuid.UUID(int=5), deterministic=True)
        writer.add_data(item)
        payload = writer.to_proto().metrics_data[0].SerializeToString()
        with pytest.raises(SummaryError, match="does not hold one summary string"):
            summary_from_data(read_metrics_data(payload))
    writer = MetricsWriter(uuid.UUID(int=5), deterministic=True)
    writer.add_data(data.strings(SUMMARY_DATA_NAME, ["not base64!"]))
    payload = writer.to_proto().metrics_data[0].SerializeToString()
    with pytest.raises(SummaryError, match="not base64"):
        summary_from_data(read_metrics_data(payload))


_names = st.text(min_size=0, max_size=6)
_jobs = st.builds(
    SummaryJob,
    st.uuids(),
    _names,
    st.sampled_from(["PASSED", "ERROR", "SOMETHING_NEW"]),
    st.none() | st.uuids(),
    st.booleans(),
    st.dictionaries(_names, st.tuples(st.floats(allow_nan=False), _names), max_size=3),
)


@examples(60)
@given(
    jobs=st.lists(_jobs, max_size=20, unique_by=lambda j: j.job_id),
    statuses=st.dictionaries(_names, st.integers(0, 2**32 - 1), max_size=4),
)
def test_any_summary_round_trips(jobs: list[SummaryJob], statuses: dict[str, int]) -> None:
    summary = BatchSummary(
        tuple(sorted(jobs, key=lambda j: j.job_id.bytes)), dict(sorted(statuses.items()))
    )
    assert decode_summary(encode_summary(summary)) == summary


def test_the_writer_of_many_jobs_writes_the_summary_of_them_all() -> None:
    # More jobs than wait to be counted at once, folded in one piece, pickled, or in two
    # merged pieces: the same summary, the one of every job, and the same bytes.
    import pickle
    from collections import Counter

    records = _records(700)
    whole = BatchSummaryWriter()
    for record in records:
        whole.update(record)
    travelled = pickle.loads(pickle.dumps(whole))
    merged, other = BatchSummaryWriter(), BatchSummaryWriter()
    for i, record in enumerate(records):
        (merged if i < 300 else other).update(record)
    merged.merge(other)
    expected = Counter(s for r in records for s in r.metric_statuses)
    for writer in (travelled, merged, whole):
        summary = writer.summary()
        assert summary.metric_statuses == dict(sorted(expected.items()))
        assert [j.job_id for j in summary.jobs] == [r.job_id for r in records]
        assert encode_summary(summary) == encode_summary(whole.summary())
        assert writer.text() == summary_text(summary)  # what finish writes
