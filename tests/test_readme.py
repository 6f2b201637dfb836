"""The docs' aggregation, writing and validation examples run as written."""

from __future__ import annotations

import uuid
from pathlib import Path

import pytest

from stook.sdk import MetricsWriter, read_job_metrics
from stook.sdk.aggregations import JobRecord, Scalar
from tests.docs_examples import block


def test_custom_aggregation_example_works() -> None:
    namespace: dict[str, object] = {}
    exec(block("docs/library.md", "class MaxOfScalar"), namespace)
    cls = namespace["MaxOfScalar"]
    left = cls(name="Worst error", metric="err")  # type: ignore[operator]
    right = left.fresh()
    for agg, values in ((left, [1.0, 5.0]), (right, [3.0])):
        for v in values:
            agg.update(JobRecord(uuid.uuid4(), "PASSED", scalars={"err": Scalar(v)}))
    left.merge(right)
    writer = MetricsWriter(uuid.UUID(int=1))
    left.finish(writer)
    view = read_job_metrics(writer.serialize())
    assert [(m.name, m.value) for m in view.metrics] == [("Worst error", 5.0)]


def test_writing_example_works(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(block("docs/sdk.md", 'w.write("metrics.binproto")'), namespace)
    view = read_job_metrics((tmp_path / "metrics.binproto").read_bytes())
    names = {m.name for m in view.metrics}
    assert names == {"Max speed", "Speed over time", "Speeds"}
    assert {d.name for d in view.data} >= {"Time", "Speed", "speeds", "accelerations"}
    scalars = namespace["view"].scalars_frame()  # type: ignore[attr-defined]
    assert scalars["value"].to_list() == [24.1]


def test_validation_example_works(capsys: pytest.CaptureFixture[str]) -> None:
    example = block("docs/sdk.md", "validate_job_metrics(read_job_metrics")
    exec(example, {})
    assert capsys.readouterr().out == ""  # valid: nothing printed
    # The same lines report each problem of an invalid message.
    broken = example.replace(
        "payload = w.serialize()",
        "w.metrics[0].proto.status = 0\npayload = w.serialize()",
    )
    exec(broken, {})
    assert "Speed" in capsys.readouterr().out
