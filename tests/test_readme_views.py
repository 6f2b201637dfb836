"""The docs' reading, merge-law, preview and emulator examples run as written."""

from __future__ import annotations

import sys
import types
import uuid
from pathlib import Path

import pytest

from stook.sdk import MetricsWriter, SeriesKind, data
from stook.sdk.aggregations import JobRecord, Scalar
from tests.docs_examples import block


def _write_example_file(path: Path) -> None:
    w = MetricsWriter(uuid.uuid4())
    w.histogram("Speeds", data.doubles("speeds", [1.0, 30.0]), buckets=2, lower=0, upper=40)
    w.bar_chart_from("Detections", {"car": 41.0, "pedestrian": 7.0})
    w.add_data(data.per_category("speeds by vehicle", SeriesKind.DOUBLE, {"car": [1.0]}))
    w.write(path)


def test_reading_outputs_example(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _write_example_file(tmp_path / "metrics.binproto")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(block("docs/sdk.md", "by_label()"), namespace)
    counts = namespace["counts"]
    assert counts.by_label() == {"car": 41.0, "pedestrian": 7.0}  # type: ignore[attr-defined]
    hist = namespace["hist"]
    assert hist.buckets == ((0.0, 20.0), (20.0, 40.0))  # type: ignore[attr-defined]


def test_merge_laws_example(monkeypatch: pytest.MonkeyPatch) -> None:
    # The class lives in a module of its own, as a user's does: check_merge_laws pickles
    # its partials, and pickle finds a class by its module and name.
    module = types.ModuleType("docs_merge_laws_example")
    monkeypatch.setitem(sys.modules, module.__name__, module)
    namespace = module.__dict__
    exec(block("docs/library.md", "class MaxOfScalar"), namespace)
    namespace["records"] = [
        JobRecord(uuid.uuid4(), "PASSED", scalars={"speed": Scalar(float(v))}) for v in (3, 9, 1)
    ]
    exec(block("docs/library.md", "check_merge_laws("), namespace)
    namespace["test_max_of_scalar_merges"]()


def test_preview_example(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _write_example_file(tmp_path / "metrics.binproto")
    monkeypatch.chdir(tmp_path)
    namespace: dict[str, object] = {}
    exec(block("docs/preview.md", "render_html("), namespace)
    html = namespace["html"]
    assert isinstance(html, str)
    assert "Detections" in html


async def test_emulator_example(tmp_path: Path) -> None:
    namespace: dict[str, object] = {}
    exec(block("docs/emulator.md", "emulated_batch("), namespace)
    await namespace["test_every_job_arrives_despite_faults"](tmp_path)  # type: ignore[operator]
