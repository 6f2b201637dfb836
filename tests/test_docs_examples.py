"""The code of the README and the docs runs as written: every Python block is run by a
test (the fetch library's, against the emulator, in tests/e2e/test_fetch_library.py), and
every TOML block is a stook.toml that stook reads."""

from __future__ import annotations

import sys
import tomllib
import types
import uuid
from pathlib import Path

import pytest

from stook.sdk import MetricsWriter, SeriesKind, data, read_job_metrics
from stook.sdk.aggregations import JobRecord, Scalar
from stook.service.modes import parse
from tests.docs_examples import EXAMPLES, ROOT, block, code_blocks, pages


@pytest.mark.parametrize("page", pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_python_block_is_run_by_a_test(page: Path) -> None:
    name = str(page.relative_to(ROOT))
    markers = [marker for (where, marker) in EXAMPLES if where == name]
    for code in code_blocks(page):
        held = [m for m in markers if m in code]
        assert len(held) == 1, f"{name}: a block no test runs:\n{code}"


def test_every_example_is_on_its_page() -> None:
    for page, marker in EXAMPLES:
        assert any(marker in code for code in code_blocks(ROOT / page)), (page, marker)
        assert (ROOT / "tests" / EXAMPLES[page, marker]).is_file()


@pytest.mark.parametrize("page", pages(), ids=lambda p: str(p.relative_to(ROOT)))
def test_every_toml_block_is_a_config_stook_reads(page: Path) -> None:
    for code in code_blocks(page, "toml"):
        doc = tomllib.loads(code)
        # Custom classes live in the reader's own modules; the rest is built as written.
        for section in ("batch", "report"):
            doc.get(section, {}).pop("custom", None)
        parse(doc, source=page.name)


# -- the examples, each run as its page shows it --


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
    # The block defines all it uses (a reader copies it whole): nothing is injected here.
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
