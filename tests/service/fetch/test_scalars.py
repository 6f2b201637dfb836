"""SCALAR metrics listed with `value: null`: their values read from the Metric message, only
when an aggregation reads them, against a real HTTP server standing in for storage."""

from __future__ import annotations

import json
import uuid
from collections.abc import Sequence
from typing import Any

import pytest
from structlog.testing import capture_logs

from stook.proto import metrics_pb2 as pb
from stook.sdk._errors import ReadError
from stook.sdk.aggregations import Needs, Scalar
from stook.service.api import RetryPolicy
from stook.service.api._models import ApiMetric, decoder
from stook.service.api._storage import StorageClient
from stook.service.fetch._scalars import read_scalar_values, read_scalars
from tests.service.scripted_server import ScriptedServer, answer

EVERY = Needs(every_scalar=True)


def _message(value: float | None, unit: str | None = None) -> bytes:
    msg = pb.Metric(name="m", type=pb.SCALAR_METRIC_TYPE, status=pb.PASSED_METRIC_STATUS)
    msg.metric_id.id.data = str(uuid.uuid4())
    if value is not None:
        msg.metric_values.scalar_metric_values.value = value
    if unit is not None:
        msg.metric_values.scalar_metric_values.unit = unit
    return msg.SerializeToString()


def _listed(name: str, server: ScriptedServer | None, **fields: Any) -> ApiMetric:
    metric_id = fields.pop("metric_id", uuid.uuid4())
    body: dict[str, Any] = {"metricID": str(metric_id), "name": name, "type": "SCALAR"}
    if server is not None:
        body["metricURL"] = server.url(f"/bucket/{metric_id}")
    return decoder(ApiMetric).decode(json.dumps(body | fields))


async def _read(
    policy: RetryPolicy,
    metrics: Sequence[ApiMetric],
    needs: Needs = EVERY,
    relisted: Sequence[ApiMetric] = (),
) -> dict[str, Scalar]:
    async def relist() -> Sequence[ApiMetric]:
        return relisted

    async with StorageClient(retry=policy) as storage:
        return await read_scalars(
            storage, metrics, needs.wants_scalar, source="job 1", relist=relist
        )


async def test_null_values_are_read_from_the_metric_message(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    listed = _listed("Max speed", server, value=None, status="FAIL_WARN")
    counted = _listed("Count", server, value=3, unit="")
    server.script(f"/bucket/{listed.metric_id}", answer(body=_message(31.5, unit="m/s")))
    scalars = await _read(fast_policy, [listed, counted])
    assert scalars == {
        "Max speed": Scalar(31.5, "m/s", "FAIL_WARN"),  # the listing's status, the message's unit
        "Count": Scalar(3.0, "", "NO_STATUS_REPORTED"),
    }
    assert [seen.path for seen in server.seen] == [f"/bucket/{listed.metric_id}"]


async def test_only_the_null_scalars_an_aggregation_reads_are_downloaded(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    wanted = _listed("Max speed", server, value=None)
    unread = _listed("Collisions", server, value=None)
    server.script(f"/bucket/{wanted.metric_id}", answer(body=_message(2.0)))
    with capture_logs() as logs:
        scalars = await _read(
            fast_policy, [wanted, unread], Needs(scalars=frozenset({"Max speed"}))
        )
    assert scalars == {"Max speed": Scalar(2.0, "", "NO_STATUS_REPORTED")}
    assert len(server.seen) == 1
    assert any(
        e["log_level"] == "debug"
        and e.get("metric") == "Collisions"
        and "no aggregation" in e["event"]
        for e in logs
    )


async def test_a_message_without_a_value_leaves_the_scalar_absent_and_says_so(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    empty = _listed("Max speed", server, value=None)
    no_url = _listed("Distance", None, value=None)
    server.script(f"/bucket/{empty.metric_id}", answer(body=_message(None)))
    with capture_logs() as logs:
        assert await _read(fast_policy, [empty, no_url]) == {}
    said = [e["event"] for e in logs if e["log_level"] == "debug"]
    assert any("no value in its listing or its message" in e for e in said)
    assert any("without a value or a URL" in e for e in said)


async def test_an_unreadable_message_is_invalid_data(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    listed = _listed("Max speed", server, value=None)
    server.script(f"/bucket/{listed.metric_id}", answer(body=b"\xff\xff not a Metric"))
    with pytest.raises(
        ReadError, match=r"could not read Metric from .job 1 / metric 'Max speed'.: not a valid"
    ):
        await _read(fast_policy, [listed])


async def test_an_expired_url_is_listed_again(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    listed = _listed("Max speed", server, value=None)
    fresh = _listed(
        "Max speed", None, value=None, metric_id=listed.metric_id, metricURL=server.url("/fresh")
    )
    server.script(f"/bucket/{listed.metric_id}", answer(403, b"<Code>AccessDenied</Code>"))
    server.script("/fresh", answer(body=_message(7.0)))
    scalars = await _read(fast_policy, [listed], relisted=[fresh])
    assert scalars == {"Max speed": Scalar(7.0, "", "NO_STATUS_REPORTED")}


async def test_unnamed_event_and_composite_metrics_are_not_scalars(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    metrics = [
        _listed("", server, value=1.0),
        _listed("event", server, value=2.0, eventMetric=True),
        _listed("plot", server, value=None, type="COMPOSITE"),
        _listed("future", server, value=None, type="MATRIX"),
        _listed("same name", server, value=4.0),
        _listed("same name", server, value=5.0),  # the last of a name wins, as listed
    ]
    assert await _read(fast_policy, metrics) == {"same name": Scalar(5.0, "", "NO_STATUS_REPORTED")}
    assert server.seen == []


async def test_a_listed_scalar_is_a_scalar_like_one_made_by_its_init(
    fast_policy: RetryPolicy,
) -> None:
    import dataclasses

    metrics = [_listed("speed", None, value=3.5, unit="m/s", status="FAIL_WARN")]
    scalar = (await _read(fast_policy, metrics))["speed"]
    assert type(scalar) is Scalar
    made = dataclasses.replace(scalar)  # every field through Scalar.__init__
    assert scalar == made == Scalar(3.5, "m/s", "FAIL_WARN")
    assert repr(scalar) == repr(made)
    assert hash(scalar) == hash(made)
    with pytest.raises(dataclasses.FrozenInstanceError):
        scalar.value = 1.0  # type: ignore[misc]


async def _values(
    policy: RetryPolicy, metrics: Sequence[ApiMetric], names: set[str]
) -> dict[str, tuple[float, str]]:
    async def relist() -> Sequence[ApiMetric]:
        return ()

    async with StorageClient(retry=policy) as storage:
        return await read_scalar_values(
            storage,
            metrics,
            EVERY.wants_scalar,
            names=names,
            source=lambda: "job 1",
            relist=relist,
        )


@pytest.mark.parametrize("null_first", [False, True])
async def test_scalar_values_are_the_scalars_as_value_and_unit(
    server: ScriptedServer, fast_policy: RetryPolicy, null_first: bool
) -> None:
    """With every value listed (one pass) and with one read from its message (as
    read_scalars): the same values, units, and names."""
    metrics = [
        _listed("", server, value=1.0),
        _listed("event", server, value=2.0, eventMetric=True),
        _listed("plot", server, value=None, type="COMPOSITE"),
        _listed("Speed", server, value=4.0, unit="m/s"),
        _listed("Speed", server, value=5.0),  # the last of a name wins, unit and all
        _listed("Count", server, value=3.0, unit="1"),
    ]
    if null_first:
        null = _listed("Count", server, value=None)
        server.script(f"/bucket/{null.metric_id}", answer(body=_message(9.0, unit="1")))
        metrics.insert(0, null)
    names = {"Before"}
    values = await _values(fast_policy, metrics, names)
    assert values == {"Speed": (5.0, ""), "Count": (3.0, "1")}
    assert list(values) == (["Count", "Speed"] if null_first else ["Speed", "Count"])
    assert names == {"Before", "Speed", "Count"}
    assert len(server.seen) == (1 if null_first else 0)


async def test_scalar_values_add_no_names_when_a_message_cannot_be_read(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    listed = _listed("Max speed", server, value=None)
    server.script(f"/bucket/{listed.metric_id}", answer(body=b"\xff\xff not a Metric"))
    names: set[str] = set()
    with pytest.raises(ReadError, match=r"job 1 / metric 'Max speed'"):
        await _values(fast_policy, [_listed("Count", server, value=3.0), listed], names)
    assert names == set()
