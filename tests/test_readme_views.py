"""The README's "Reading outputs" and merge-law examples run as written."""

from __future__ import annotations

import sys
import types
import uuid
from pathlib import Path

import pytest

from stook.sdk import MetricsWriter, SeriesKind, data
from stook.sdk.aggregations import JobRecord, Scalar
from tests.test_readme import _block


def test_reading_outputs_example(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    w = MetricsWriter(uuid.uuid4())
    w.histogram("Speeds", data.doubles("speeds", [1.0, 30.0]), buckets=2, lower=0, upper=40)
    w.bar_chart_from("Detections", {"car": 41.0, "pedestrian": 7.0})
    w.add_data(data.per_category("speeds by vehicle", SeriesKind.DOUBLE, {"car": [1.0]}))
    w.write(tmp_path / "metrics.binproto")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(_block("by_label()"), namespace)
    counts = namespace["counts"]
    assert counts.by_label() == {"car": 41.0, "pedestrian": 7.0}  # type: ignore[attr-defined]
    hist = namespace["hist"]
    assert hist.buckets == ((0.0, 20.0), (20.0, 40.0))  # type: ignore[attr-defined]


def test_merge_laws_example(monkeypatch: pytest.MonkeyPatch) -> None:
    # The class lives in a module of its own, as a user's does: check_merge_laws pickles
    # its partials, and pickle finds a class by its module and name.
    module = types.ModuleType("readme_merge_laws_example")
    monkeypatch.setitem(sys.modules, module.__name__, module)
    namespace = module.__dict__
    exec(_block("class MaxOfScalar"), namespace)
    namespace["records"] = [
        JobRecord(uuid.uuid4(), "PASSED", scalars={"speed": Scalar(float(v))}) for v in (3, 9, 1)
    ]
    exec(_block("check_merge_laws("), namespace)
    namespace["test_max_of_scalar_merges"]()
