"""One failing metric among good ones, as the platform shows it: the failing one present
under its name, marked ERROR or RENDER_ERROR, said once on stderr; the good ones exactly
as in a run without the failure; exit 0. `--strict` and `[metrics_config] strict`: exit
4 and nothing written. Also the metrics' order, and events' statuses and metrics."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from stook.sdk import (
    MetricStatus,
    PlotlyMetric,
    ScalarMetric,
    TextMetric,
    read_job_metrics,
    validate_job_metrics,
)
from stook.service.cli._main import run_cli
from stook.testing.metrics_config_fixture import write_fixture
from tests.service.metrics_config.emitted import JobData, emit_job, make_job

MAX_SPEED_QUERY = 'SELECT MAX(speed) AS "Max speed" FROM speed'


@pytest.fixture(autouse=True)
def _console_errors(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STOOK_LOG_FORMAT", "console")


def _eval(config: Path, emissions: Path, out: Path, *extra: str) -> int:
    argv = ["metrics-config", "eval", str(config), "--emissions", str(emissions)]
    return run_cli([*argv, "--level", "test", "--outputs", str(out), *extra])


def _broken(tmp_path: Path, old: str, new: str) -> Path:
    """The fixture config with `old` replaced by `new`, laid out with its template."""
    config = write_fixture(tmp_path / "broken")
    text = config.read_text(encoding="utf-8")
    assert old in text
    config.write_text(text.replace(old, new, 1), encoding="utf-8")
    return config


def _by_name(out: Path) -> dict[str, bytes]:
    view = read_job_metrics((out / "metrics.binproto").read_bytes())
    validate_job_metrics(view.raw)
    return {m.name: m.raw.SerializeToString() for m in view.metrics if not m.event_metric}


@pytest.mark.parametrize(
    ("name", "old", "new", "mark", "said"),
    [
        (
            "Max speed",
            MAX_SPEED_QUERY,
            "SELECT MAX(CAST(lane AS INTEGER)) FROM speed",
            "ERROR",
            "its query failed: Conversion Error",
        ),
        (
            "Max speed",
            "SELECT 1 FROM speed HAVING MAX(speed) > ?",
            "SELECT 1 FROM speed HAVING MAX(CAST(lane AS INTEGER)) > ?",
            "ERROR",
            "its status query failed",
        ),
        (
            "Max speed",
            MAX_SPEED_QUERY,
            'SELECT ARRAY[MAX(speed)] AS "Max speed" FROM speed',
            "RENDER_ERROR",
            "a scalar is a number or a text",
        ),
        (
            "Speed over time",
            'speed AS "Speed (m/s)"',
            'CAST(speed AS VARCHAR) AS "Speed (m/s)"',
            "RENDER_ERROR",
            "not a number",
        ),
        (
            "Speed distribution",
            "bins: 10",
            "bins: lots",
            "RENDER_ERROR",
            "template_settings.display.bins must be a positive int",
        ),
    ],
)
def test_a_failing_metric_is_marked_and_the_others_keep_their_values(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    name: str,
    old: str,
    new: str,
    mark: str,
    said: str,
) -> None:
    job = make_job(0)
    good_config = write_fixture(tmp_path / "good")
    emissions = emit_job(tmp_path / "job", good_config, job)
    assert _eval(good_config, emissions, tmp_path / "good-out") == 0
    capsys.readouterr()
    good = _by_name(tmp_path / "good-out")

    config = _broken(tmp_path, old, new)
    assert _eval(config, emissions, tmp_path / "out") == 0
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert err.count(f"metric {name!r}") == 1  # said once, naming the metric
    assert f"stook: {mark}: metric {name!r}" in err
    assert said in err

    written = _by_name(tmp_path / "out")
    assert set(written) == set(good)  # the failing one present, the others all written
    for other in good:
        if other != name:
            assert written[other] == good[other], other  # values, ids, order: all the same
    view = read_job_metrics((tmp_path / "out" / "metrics.binproto").read_bytes())
    failed = view.metric(name, TextMetric)
    assert failed.status is MetricStatus.NOT_APPLICABLE
    assert dict(failed.view.tags) == {"error": mark}
    assert said in failed.text
    assert not failed.text.startswith("metric ")  # the name is the metric's own
    assert failed.view.order == view.find_metric(name).order  # type: ignore[union-attr]


def test_a_template_error_and_a_missing_image_are_render_errors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = write_fixture(tmp_path / "repo")
    job = make_job(0)
    emissions = emit_job(tmp_path / "job", config, job)
    (emissions.parent / job.frame).unlink()
    (config.parent / "templates" / "speed_figure.liquid").write_text("{{ t", encoding="utf-8")
    assert _eval(config, emissions, tmp_path / "out") == 0
    err = capsys.readouterr().err.splitlines()
    failures = [line for line in err if line.startswith("stook: RENDER_ERROR: ")]
    assert len(failures) == 2
    assert any(f"attached file {job.frame!r} is in no job's folder" in f for f in failures)
    view = read_job_metrics((tmp_path / "out" / "metrics.binproto").read_bytes())
    for name in ("Speed figure", "Camera frame"):
        assert ("error", "RENDER_ERROR") in view.metric(name, TextMetric).view.tags
    assert not (tmp_path / "out" / job.frame).exists()
    assert view.metric("Max speed", ScalarMetric).value == max(s for _, _, s in job.speed)


def test_strict_is_exit_4_and_writes_nothing(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = _broken(tmp_path, MAX_SPEED_QUERY, "SELECT MAX(CAST(lane AS INTEGER)) FROM speed")
    emissions = emit_job(tmp_path / "job", config, make_job(0))
    out = tmp_path / "out"
    assert _eval(config, emissions, out, "--strict") == 4
    err = capsys.readouterr().err
    assert "metric 'Max speed': its query failed" in err
    assert not out.exists()


def _test_mode(tmp_path: Path, config: Path, job: JobData, strict: bool) -> tuple[int, Path]:
    emissions = emit_job(tmp_path / "job", config, job)
    inputs = tmp_path / "inputs"
    (inputs / "experience").mkdir(parents=True)
    (inputs / "logs").mkdir()
    shutil.copy(emissions, inputs / "logs" / "emissions.resim.jsonl")
    shutil.copy(emissions.parent / job.frame, inputs / "logs" / job.frame)
    toml = tmp_path / "stook.toml"
    setting = "strict = true\n" if strict else ""
    toml.write_text(f'[metrics_config]\npaths = ["{config}"]\n{setting}', encoding="utf-8")
    out = tmp_path / "out"
    argv = ["run", "--inputs", str(inputs), "--outputs", str(out), "--config", str(toml)]
    return run_cli([*argv, "--log-level", "warning"]), out


@pytest.mark.parametrize("strict", [False, True])
def test_in_a_metrics_build_strict_is_a_setting(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], strict: bool
) -> None:
    config = _broken(tmp_path, MAX_SPEED_QUERY, "SELECT MAX(CAST(lane AS INTEGER)) FROM speed")
    code, out = _test_mode(tmp_path, config, make_job(0), strict)
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert len([line for line in err.splitlines() if "Max speed" in line]) == 1  # said once
    if strict:
        assert code == 4
        assert not any(out.glob("*.binproto"))
        return
    assert code == 0
    (written,) = out.glob("*.binproto")
    view = read_job_metrics(written.read_bytes())
    assert ("error", "ERROR") in view.metric("Max speed", TextMetric).view.tags
    assert "config metric written as an error" in err


def test_the_metrics_follow_their_sets_order(tmp_path: Path) -> None:
    config = write_fixture(tmp_path / "repo")
    emissions = emit_job(tmp_path / "job", config, make_job(0))
    assert _eval(config, emissions, tmp_path / "core", "--metrics-set", "core") == 0
    view = read_job_metrics((tmp_path / "core" / "metrics.binproto").read_bytes())
    shown = sorted((m for m in view.metrics if not m.event_metric), key=lambda m: m.order or 0)
    # the set lists Max speed first; the config defines Speed over time first
    assert [m.name for m in shown] == [
        "Max speed",
        "Speed over time",
        "Detections by label",
        "Worst lidar dropout",
    ]
    assert [m.order for m in shown] == [0.0, 1.0, 2.0, 3.0]
    assert all(m.order is None for m in view.metrics if m.event_metric)


EVENT_METRICS = [
    {"name": "impact speed", "type": "scalar", "value": 3.5, "unit": "m/s"},
    {"name": "log", "type": "text", "value": "brake applied late"},
    {"name": "contacts", "type": "table", "value": [{"part": "bumper", "depth": 0.1}]},
    {"name": "per axis", "type": "table", "value": {"axis": ["x", "y"], "g": [1.5, 0.5]}},
    {"name": "trace", "type": "line", "value": {"data": [{"type": "scatter", "y": [1, 2]}]}},
    {"name": "odd", "type": "bar", "value": [1, 2, 3]},
]


def test_event_statuses_count_and_their_metrics_are_rendered(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # Only the core set's metrics (none blocks on this job): the event's FAIL_BLOCK counts.
    config = write_fixture(tmp_path / "repo")
    job = make_job(0)
    job.collisions[0]["status"] = "FAIL_BLOCK"
    job.collisions[0]["metrics"] = EVENT_METRICS
    emissions = emit_job(tmp_path / "job", config, job)
    out = tmp_path / "out"
    assert _eval(config, emissions, out, "--metrics-set", "core") == 0
    view = read_job_metrics((out / "metrics.binproto").read_bytes())
    validate_job_metrics(view.raw)
    assert all(m.status is not MetricStatus.FAIL_BLOCK for m in view.metrics)
    assert view.status is MetricStatus.FAIL_BLOCK

    (event,) = view.events
    assert event.status is MetricStatus.FAIL_BLOCK
    texts = {m.name: m.raw.metric_values.text_metric_values.text for m in view.metrics}
    assert texts["log"] == "brake applied late"
    assert texts["contacts"].splitlines() == ["| part | depth |", "|---|---|", "| bumper | 0.1 |"]
    assert texts["per axis"].splitlines()[2:] == ["| x | 1.5 |", "| y | 0.5 |"]
    assert json.loads(texts["odd"].removeprefix("```json\n").removesuffix("\n```")) == [1, 2, 3]
    assert view.metric("trace", PlotlyMetric).json["data"][0]["y"] == [1, 2]
    assert view.metric("impact speed", ScalarMetric).value == 3.5
    assert "{" not in texts["contacts"]  # no Python repr


def test_strict_in_stook_toml_is_a_boolean() -> None:
    from stook.service.modes import ConfigError, parse

    table = {"paths": ["a.yml"]}
    for given, strict in (({}, False), ({"strict": True}, True)):
        settings = parse({"metrics_config": {**table, **given}}).metrics_config
        assert settings is not None
        assert settings.strict is strict
    with pytest.raises(ConfigError, match=r"\[metrics_config\] 'strict' must be true or false"):
        parse({"metrics_config": {**table, "strict": "yes"}})
