"""The pieces of a sharded run: `[engine]` parsing, the split, errors carried back from a
worker, the missing-jobs order, and which states travel (see tests/e2e/test_engines*.py
for whole runs)."""

from __future__ import annotations

import pickle
import sys
import threading
import uuid
from dataclasses import dataclass, field

import pytest

from stook.sdk import MetricsWriter, read_job_metrics
from stook.sdk.aggregations import (
    BatchAggregation,
    BatchSummaryWriter,
    JobRecord,
    default_batch_aggregations,
)
from stook.sdk.aggregations.report import default_report_aggregations
from stook.service.api import AuthError, NotFoundError
from stook.service.fetch import MissingJob
from stook.service.modes import ConfigError, EngineSettings, StookConfig, engine_for, parse
from stook.service.modes._config import parse_engine, require_engine
from stook.service.modes._engine import check_states_pickle
from stook.service.modes._errors import EngineConfigError, ShardError
from stook.service.modes._pipeline import write_missing_jobs
from stook.service.modes._shards import RemoteError, split


def test_engine_defaults_to_local() -> None:
    assert parse({}).engine == EngineSettings(kind="local")


def test_engine_table_is_read() -> None:
    doc = {"engine": {"kind": "ray", "workers": 4, "shards": 16, "address": "auto"}}
    assert parse(doc).engine == EngineSettings("ray", 4, 16, "auto")


@pytest.mark.parametrize(
    ("table", "said"),
    [
        ({"kind": "spark"}, "[engine] kind must be one of 'local', 'processes', 'ray'"),
        ({"kind": "processes", "workers": 0}, "[engine] workers must be a positive integer, got 0"),
        (
            {"kind": "processes", "workers": True},
            "[engine] workers must be a positive integer, got the boolean true",
        ),
        (
            {"kind": "processes", "shards": 2.5},
            "[engine] shards must be a positive integer, got the float 2.5",
        ),
        ({"kind": "local", "address": "auto"}, '[engine] address is for kind = "ray"'),
        ({"kind": "ray", "address": 7}, "[engine] address must be a Ray address"),
        ({"nodes": 3}, "unknown key 'nodes' in [engine]"),
    ],
)
def test_bad_engine_settings_name_the_key(table: dict[str, object], said: str) -> None:
    with pytest.raises(ConfigError, match=None) as caught:
        parse({"engine": table}, source="stook.toml")
    assert str(caught.value).startswith("stook.toml: ")
    assert said in str(caught.value)


def test_ray_missing_is_named_with_its_extra(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` fails, as if not installed
    with pytest.raises(EngineConfigError, match=r'pip install "stook\[ray\]"'):
        require_engine(EngineSettings(kind="ray"))
    require_engine(EngineSettings(kind="processes"))  # needs nothing extra
    config = StookConfig(engine=parse_engine({"kind": "ray"}))
    with pytest.raises(ConfigError, match=r"^\(built-in defaults\): \[engine\] kind"):
        engine_for(config)
    assert engine_for(config, "local").kind == "local"  # --engine local needs no Ray
    with pytest.raises(ConfigError, match=r"^--engine: "):
        engine_for(StookConfig(), "ray")


def test_the_engine_flag_keeps_the_table_s_other_settings() -> None:
    config = StookConfig(engine=EngineSettings("ray", workers=3, shards=9, address="auto"))
    assert engine_for(config, "processes") == EngineSettings("processes", 3, 9, None)


@pytest.mark.parametrize(("items", "shards"), [(10, 3), (3, 8), (7, 7), (100, 1), (0, 4)])
def test_split_is_contiguous_even_and_never_empty(items: int, shards: int) -> None:
    pieces = split(list(range(items)), shards)
    assert [x for piece in pieces for x in piece] == list(range(items))
    assert len(pieces) == min(items, shards)
    sizes = {len(piece) for piece in pieces}
    assert not sizes or (min(sizes) >= 1 and max(sizes) - min(sizes) <= 1)


def test_our_errors_come_back_with_their_type_and_message() -> None:
    refused = AuthError(status=401, method="GET", url="https://api.example/v1/jobs", body=b"no")
    back = pickle.loads(pickle.dumps(RemoteError.of(refused))).rebuild()
    assert type(back) is AuthError
    assert str(back) == str(refused)
    assert not getattr(back, "__notes__", None)  # stook's own errors need no traceback


def test_other_errors_bring_the_worker_s_traceback() -> None:
    try:
        raise ValueError("a user's aggregation failed")
    except ValueError as error:
        remote = RemoteError.of(error)
    back = remote.rebuild()
    assert type(back) is ValueError
    assert "a user's aggregation failed" in str(back)
    assert "in a worker" in back.__notes__[0]
    assert "Traceback" in back.__notes__[0]


def test_an_error_class_the_driver_cannot_import_becomes_a_shard_error() -> None:
    back = RemoteError("no.such.module", "Gone", "it went").rebuild()
    assert isinstance(back, ShardError)
    assert str(back) == "Gone: it went"


def test_missing_jobs_are_written_in_job_id_order() -> None:
    ids = sorted(uuid.uuid4() for _ in range(4))
    missing = [MissingJob(i, "exp", "HTTP 500") for i in reversed(ids)]
    writer = MetricsWriter(uuid.uuid4(), deterministic=True)
    write_missing_jobs(writer, missing, jobs=10, allowed=0.5)
    view = read_job_metrics(writer.serialize())
    text = view.metrics[0].raw.metric_values.text_metric_values.text
    listed = [line.split()[1] for line in text.splitlines() if line.startswith("- ")]
    assert listed == [str(i) for i in ids]
    with pytest.raises(Exception, match=f"job {ids[0]} and 3 more"):
        write_missing_jobs(writer, missing, jobs=10, allowed=0.1)


def test_every_built_in_state_pickles() -> None:
    built_ins = [*default_batch_aggregations(), BatchSummaryWriter()]
    built_ins += default_report_aggregations(project_id=str(uuid.uuid4()))
    for aggregation in built_ins:
        state = aggregation.fresh()
        assert type(pickle.loads(pickle.dumps(state))) is type(state)


def test_not_found_keeps_its_type() -> None:
    missing = NotFoundError(status=404, method="GET", url="https://api.example/v1/x")
    assert type(RemoteError.of(missing).rebuild()) is NotFoundError


@dataclass
class HoldsALock(BatchAggregation):
    name: str = "Holds a lock"
    lock: threading.Lock = field(default_factory=threading.Lock, init=False)

    def update(self, record: JobRecord) -> None:
        pass

    def merge(self, other: HoldsALock) -> None:
        pass

    def finish(self, writer: MetricsWriter) -> None:
        pass


def test_a_state_that_cannot_travel_is_a_config_error() -> None:
    with pytest.raises(ConfigError, match=r"aggregation 'Holds a lock' \(HoldsALock\) cannot be"):
        check_states_pickle([*default_batch_aggregations(), HoldsALock()])
    check_states_pickle(default_batch_aggregations())
