"""Test mode with [metrics_config]: the config's `type: test` metrics beside a [test]
metrics function's, from the emissions file in the inputs' logs/."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from stook.sdk import MetricStatus, ScalarMetric, read_job_metrics
from stook.service.cli._main import run_cli
from stook.service.modes import ConfigError, parse
from tests.service.metrics_config.emitted import JobData

USER_MODULE = """\
def compute(experience_dir, logs_dir, writer):
    writer.scalar("From the function", 1.0)
"""


def _inputs(tmp_path: Path, one_job: tuple[Path, JobData]) -> Path:
    emissions, job = one_job
    inputs = tmp_path / "inputs"
    (inputs / "experience").mkdir(parents=True)
    (inputs / "logs").mkdir()
    shutil.copy(emissions, inputs / "logs" / "emissions.resim.jsonl")
    shutil.copy(emissions.parent / job.frame, inputs / "logs" / job.frame)
    return inputs


def test_config_metrics_are_written_beside_the_functions(
    tmp_path: Path, config: Path, one_job: tuple[Path, JobData]
) -> None:
    inputs = _inputs(tmp_path, one_job)
    (tmp_path / "user_metrics_mc.py").write_text(USER_MODULE, encoding="utf-8")
    toml = tmp_path / "stook.toml"
    relative = config.relative_to(tmp_path)
    toml.write_text(
        f'[test]\nmetrics = "user_metrics_mc:compute"\n\n'
        f'[metrics_config]\npaths = ["{relative}"]\nmetrics_set = "core"\n',
        encoding="utf-8",
    )
    out = tmp_path / "out"
    code = run_cli(
        [
            "run",
            "--inputs",
            str(inputs),
            "--outputs",
            str(out),
            "--config",
            str(toml),
            "--log-level",
            "error",
        ]
    )
    assert code == 0
    view = read_job_metrics((out / "metrics.binproto").read_bytes())
    names = {m.name for m in view.metrics if not m.event_metric}
    assert names == {
        "From the function",
        "Max speed",
        "Speed over time",
        "Detections by label",
        "Worst lidar dropout",
    }
    top = view.metric("Max speed", ScalarMetric)
    assert top.value == max(s for _, _, s in one_job[1].speed)
    assert len(view.events) == 1  # the collision event, at test level
    # "core" lacks the blocking Lidar samples; the collision event's FAIL_WARN counts.
    assert view.status is MetricStatus.FAIL_WARN


def test_without_an_emissions_file_the_metrics_see_no_rows(tmp_path: Path, config: Path) -> None:
    inputs = tmp_path / "inputs"
    (inputs / "logs").mkdir(parents=True)
    (inputs / "experience").mkdir()
    toml = tmp_path / "stook.toml"
    toml.write_text(f'[metrics_config]\npaths = ["{config}"]\n', encoding="utf-8")
    out = tmp_path / "out"
    code = run_cli(
        [
            "run",
            "--inputs",
            str(inputs),
            "--outputs",
            str(out),
            "--config",
            str(toml),
            "--log-level",
            "error",
        ]
    )
    assert code == 0
    view = read_job_metrics((out / "metrics.binproto").read_bytes())
    # every query over no rows: NO_DATA, or hidden; COUNT(*)-free config: nothing blocks
    assert view.find_metric("Lidar dropouts") is None
    speed = view.find_metric("Max speed")
    assert speed is not None
    assert speed.status is MetricStatus.NOT_APPLICABLE


def test_a_bad_config_fails_before_the_function_runs(
    tmp_path: Path,
    one_job: tuple[Path, JobData],
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("STOOK_LOG_FORMAT", "console")
    inputs = _inputs(tmp_path, one_job)
    (tmp_path / "bad.yml").write_text("topics: {}\n", encoding="utf-8")
    toml = tmp_path / "stook.toml"
    toml.write_text('[metrics_config]\npaths = ["bad.yml"]\n', encoding="utf-8")
    out = tmp_path / "out"
    code = run_cli(["run", "--inputs", str(inputs), "--outputs", str(out), "--config", str(toml)])
    assert code == 2
    assert "'version' is required" in capsys.readouterr().err
    assert not (out / "metrics.binproto").exists()


@pytest.mark.parametrize(
    ("table", "problem"),
    [
        ({"paths": []}, "'paths' must be a non-empty list"),
        ({"paths": ["a.yml"], "set": "x"}, "unknown key 'set'"),
        ({"paths": ["a.yml"], "metrics_set": 3}, "'metrics_set' must be a string"),
    ],
)
def test_the_stook_toml_table_is_checked(table: dict[str, object], problem: str) -> None:
    with pytest.raises(ConfigError, match=problem):
        parse({"metrics_config": table})
