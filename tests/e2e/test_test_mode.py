"""Test mode through the real CLI: no batch config, so experience/ and logs/ are the inputs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
import resim.metrics.proto.metrics_pb2 as rp

from stook.sdk import MetricType
from stook.service.cli import run_cli
from tests.e2e.support import OUTPUT_NAME, by_name, outputs_left, read_output
from tests.e2e.user_metrics import ASYNC_VALUE
from tests.failures import failure_lines, traceback_text

# No ./stook.toml and no STOOK_* settings from the environment (tests/e2e/conftest.py).
pytestmark = pytest.mark.usefixtures("isolated")


@pytest.fixture
def inputs(tmp_path: Path) -> Path:
    folder = tmp_path / "inputs"
    (folder / "experience").mkdir(parents=True)
    (folder / "logs").mkdir()
    (folder / "logs" / "run.log").write_text("start\nstep\nstep\nstop\n")
    return folder


def stook_run(
    capsys: pytest.CaptureFixture[str], inputs: Path, toml: str | None
) -> tuple[int, str, Path]:
    outputs = inputs.parent / "outputs"
    argv = ["run", "--inputs", str(inputs), "--outputs", str(outputs), "--log-format", "json"]
    if toml is not None:
        config = inputs.parent / "stook.toml"
        config.write_text(toml)
        argv += ["--config", str(config)]
    code = run_cli(argv)
    return code, capsys.readouterr().err, outputs


def log_events(err: str) -> list[dict[str, object]]:
    return [json.loads(line) for line in err.splitlines() if line.startswith("{")]


def test_no_config_writes_a_valid_empty_output_and_warns(
    capsys: pytest.CaptureFixture[str], inputs: Path
) -> None:
    code, err, outputs = stook_run(capsys, inputs, None)
    assert code == 0, err
    view = read_output(outputs / OUTPUT_NAME)
    assert view.metrics == ()
    assert view.data == ()
    warnings = [e for e in log_events(err) if e.get("level") == "warning"]
    assert any("no [test] metrics function" in str(e["event"]) for e in warnings), err
    assert outputs_left(outputs) == [OUTPUT_NAME]


def test_the_example_writes_every_metric_type(
    capsys: pytest.CaptureFixture[str], inputs: Path
) -> None:
    code, err, outputs = stook_run(
        capsys, inputs, '[test]\nmetrics = "stook.sdk.example:every_metric_type"\n'
    )
    assert code == 0, err
    view = read_output(outputs / OUTPUT_NAME)  # ReSim's validator accepts it
    written = {m.type.name for m in view.metrics if isinstance(m.type, MetricType)}
    every = {
        name.removesuffix("_METRIC_TYPE")
        for name, _ in rp.MetricType.items()
        if name != "NO_METRIC_TYPE"
    }
    assert len(every) == 12
    assert written == every


def test_a_user_function_that_raises(capsys: pytest.CaptureFixture[str], inputs: Path) -> None:
    code, err, outputs = stook_run(
        capsys, inputs, '[test]\nmetrics = "tests.e2e.user_metrics:raises"\n'
    )
    assert code == 1
    # The user's own traceback, down to the frame that raised.
    shown = traceback_text(err)
    assert "Traceback (most recent call last)" in shown
    assert 'user_metrics.py", line' in shown
    assert "in _lane_model_step" in shown
    assert "RuntimeError: lane model diverged on experience" in shown
    errors = failure_lines(err)
    assert len(errors) == 1
    assert "tests.e2e.user_metrics:raises" in errors[0]
    assert outputs_left(outputs) == []


def test_an_async_user_function(capsys: pytest.CaptureFixture[str], inputs: Path) -> None:
    code, err, outputs = stook_run(
        capsys, inputs, '[test]\nmetrics = "tests.e2e.user_metrics:async_metrics"\n'
    )
    assert code == 0, err
    metrics = by_name(read_output(outputs / OUTPUT_NAME))
    assert set(metrics) == {"Log lines", "Async value"}
    assert metrics["Log lines"].value == 4.0
    assert metrics["Async value"].value == ASYNC_VALUE
    assert metrics["Async value"].unit == "m"


def test_a_function_that_cannot_be_imported(
    capsys: pytest.CaptureFixture[str], inputs: Path
) -> None:
    code, err, outputs = stook_run(
        capsys, inputs, '[test]\nmetrics = "tests.e2e.user_metrics:no_such_function"\n'
    )
    assert code == 2
    errors = failure_lines(err)
    assert len(errors) == 1
    assert "tests.e2e.user_metrics:no_such_function" in errors[0]
    assert "Traceback" not in err
    assert outputs_left(outputs) == []
