"""The README's aggregation and validation examples run as written."""

from __future__ import annotations

import re
import uuid
from pathlib import Path

import pytest

from stook.sdk import MetricsWriter, read_job_metrics
from stook.sdk.aggregations import JobRecord, Scalar

README = Path(__file__).resolve().parent.parent / "README.md"


def _block(containing: str) -> str:
    blocks: list[str] = re.findall(r"```python\n(.*?)```", README.read_text(encoding="utf-8"), re.S)
    return next(b for b in blocks if containing in b)


def test_readme_custom_aggregation_example_works() -> None:
    namespace: dict[str, object] = {}
    exec(_block("class MaxOfScalar"), namespace)
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


def test_readme_validation_example_works(capsys: pytest.CaptureFixture[str]) -> None:
    namespace: dict[str, object] = {}
    exec(_block("validate_job_metrics(read_job_metrics"), namespace)
    assert capsys.readouterr().out == ""  # valid: nothing printed
    # The same lines report each problem of an invalid message.
    broken = _block("validate_job_metrics(read_job_metrics").replace(
        "payload = w.serialize()",
        "w.metrics[0].proto.status = 0\npayload = w.serialize()",
    )
    exec(broken, {})
    assert "Speed" in capsys.readouterr().out
