"""`stook run` from real bad inputs to each documented exit code.

Every failure must print exactly one ``stook: error:`` line naming what is at fault, no
traceback (unless the user's own code raised), and leave no metrics.binproto behind.
"""

from __future__ import annotations

import dataclasses
import json
import os
import socket
import subprocess
import sys
import time
import uuid
from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.emulator import Emulator, MetricsOutput
from stook.sdk import MetricStatus, MetricType
from stook.service.cli import run_cli
from tests.e2e.support import (
    BATCH_TOML,
    OUTPUT_NAME,
    EmulatorThread,
    assert_matches_truth,
    by_name,
    config,
    expected_from_truth,
    outputs_left,
    read_output,
    text_of,
)
from tests.failures import failure_lines, traceback_text

REPO = Path(__file__).resolve().parents[2]
BROKEN = 3  # index of a job with metrics (6 is the job that never wrote any)
FAST_FETCH = "[fetch]\nretry_for = 2\ntimeout = 5.0\n"


# No ./stook.toml and no STOOK_* settings from the environment (tests/e2e/conftest.py).
pytestmark = pytest.mark.usefixtures("isolated")


@pytest.fixture(scope="module")
def emu() -> Iterator[Emulator]:
    with EmulatorThread(config(jobs_per_batch=40, seed=31)) as emulator:
        yield emulator


@pytest.fixture(scope="module")
def broken_emu() -> Iterator[Emulator]:
    with EmulatorThread(config(jobs_per_batch=40, seed=31, broken_jobs=(BROKEN,))) as emulator:
        yield emulator


def batch_config(emu: Emulator, **changes: str) -> dict[str, str]:
    return {
        "authToken": emu.token,
        "apiURL": emu.api_url,
        "batchID": str(emu.batch_id),
        "projectID": str(emu.project_id),
        **changes,
    }


def write_json(inputs: Path, body: object, name: str = "batch_metrics_config.json") -> None:
    inputs.mkdir(parents=True, exist_ok=True)
    (inputs / name).write_text(json.dumps(body) if not isinstance(body, str) else body)


def stook_run(
    capsys: pytest.CaptureFixture[str], tmp: Path, *extra: str, toml: str | None = None
) -> tuple[int, str]:
    argv = ["run", "--inputs", str(tmp / "inputs"), "--outputs", str(tmp / "outputs")]
    if toml is not None:
        (tmp / "stook.toml").write_text(toml)
        argv += ["--config", str(tmp / "stook.toml")]
    code = run_cli([*argv, "--log-format", "json", *extra])
    _, err = capsys.readouterr()
    return code, err


def assert_failed(err: str, outputs: Path, *named: str, traceback: bool = False) -> str:
    lines = failure_lines(err)
    assert len(lines) == 1, err
    for thing in named:
        assert thing in lines[0], f"{thing!r} not named in {lines[0]!r}"
    assert ("Traceback (most recent call last)" in err) is traceback, err
    assert outputs_left(outputs) == []
    # Not even the folder: these tests' outputs folders do not exist before the run, and a
    # failed run removes the empty one it made.
    assert not outputs.exists(), f"a failed run left {outputs}"
    return lines[0]


# ---- 2: bad usage, config or inputs ----


def test_malformed_batch_config(capsys: pytest.CaptureFixture[str], tmp_path: Path) -> None:
    write_json(tmp_path / "inputs", '{"authToken": "abc", "apiURL": ')
    code, err = stook_run(capsys, tmp_path)
    assert code == 2, err
    assert_failed(err, tmp_path / "outputs", "batch_metrics_config.json", "not valid JSON")


def test_missing_key(capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator) -> None:
    body = batch_config(emu)
    del body["batchID"]
    write_json(tmp_path / "inputs", body)
    code, err = stook_run(capsys, tmp_path)
    assert code == 2, err
    assert_failed(err, tmp_path / "outputs", "batch_metrics_config.json", "'batchID'", "missing")


def test_batch_id_that_is_not_a_uuid(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    write_json(tmp_path / "inputs", batch_config(emu, batchID="nightly-batch-42"))
    code, err = stook_run(capsys, tmp_path)
    assert code == 2, err
    assert_failed(err, tmp_path / "outputs", "'batchID'", "nightly-batch-42", "not a UUID")


def test_bad_toml(capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator) -> None:
    write_json(tmp_path / "inputs", batch_config(emu))
    before = emu.stats.requests["api"]
    code, err = stook_run(capsys, tmp_path, toml="[fetch\nconcurrency = 4\n")
    assert code == 2, err
    assert_failed(err, tmp_path / "outputs", "stook.toml", "not valid TOML")
    assert emu.stats.requests["api"] == before  # refused before any fetching


def test_unknown_section(capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator) -> None:
    write_json(tmp_path / "inputs", batch_config(emu))
    before = emu.stats.requests["api"]
    code, err = stook_run(capsys, tmp_path, toml="[fetchh]\nconcurrency = 4\n")
    assert code == 2, err
    assert emu.stats.requests["api"] == before  # refused before any fetching
    assert_failed(err, tmp_path / "outputs", "stook.toml", "unknown section 'fetchh'")


def test_unknown_metric_in_a_weighted_mean(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    write_json(tmp_path / "inputs", batch_config(emu))
    toml = BATCH_TOML.replace('metric = "Localization error"', 'metric = "Localisation error"')
    code, err = stook_run(capsys, tmp_path, toml=toml)
    assert code == 2, err
    line = assert_failed(
        err,
        tmp_path / "outputs",
        "stook.toml",
        "no job in the batch has a scalar metric named 'Localisation error'",
    )
    assert "did you mean 'Localization error'" in line


def test_unknown_data_in_a_histogram(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    write_json(tmp_path / "inputs", batch_config(emu))
    code, err = stook_run(capsys, tmp_path, toml=BATCH_TOML.replace('"speeds"', '"speed"'))
    assert code == 2, err
    assert_failed(err, tmp_path / "outputs", "stook.toml", "metrics data named 'speed'")


def test_unknown_report(capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator) -> None:
    unknown = uuid.uuid4()
    config = {
        "authToken": emu.token,
        "apiURL": emu.api_url,
        "reportID": str(unknown),
        "projectID": str(emu.project_id),
    }
    write_json(tmp_path / "inputs", config, name="report_config.json")
    code, err = stook_run(capsys, tmp_path)
    assert code == 3, err
    assert_failed(err, tmp_path / "outputs", f"report {unknown} does not exist")


# ---- 3: the API refused or failed ----


def test_wrong_token(capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator) -> None:
    wrong = "wrong-token-" + uuid.uuid4().hex
    write_json(tmp_path / "inputs", batch_config(emu, authToken=wrong))
    code, err = stook_run(capsys, tmp_path)
    assert code == 3
    assert_failed(err, tmp_path / "outputs", "401")
    assert wrong not in err


def test_unreachable_api(capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator) -> None:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    # Closed now: nothing listens on the port.
    url = f"http://127.0.0.1:{port}/v1"
    write_json(tmp_path / "inputs", batch_config(emu, apiURL=url))
    code, err = stook_run(capsys, tmp_path, toml="[fetch]\nretry_for = 2\ntimeout = 2.0\n")
    assert code == 3
    assert_failed(err, tmp_path / "outputs", f"the API at http://127.0.0.1:{port}", "apiURL")


def test_an_api_host_that_does_not_resolve_ends_the_run_at_once(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    """Not the whole retry_for (120 s): a name that never resolved is a wrong apiURL."""
    url = "http://nonexistent.invalid:8080/v1"
    write_json(tmp_path / "inputs", batch_config(emu, apiURL=url))
    started = time.monotonic()
    code, err = stook_run(capsys, tmp_path)
    assert code == 3
    assert time.monotonic() - started < 5.0
    assert_failed(err, tmp_path / "outputs", "nonexistent.invalid:8080", "apiURL")


@pytest.mark.slow
def test_a_refused_api_gets_the_short_first_contact_budget(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    with socket.socket() as sock:  # bound, never listening: connections are refused
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
        write_json(tmp_path / "inputs", batch_config(emu, apiURL=f"http://127.0.0.1:{port}/v1"))
        started = time.monotonic()
        code, err = stook_run(capsys, tmp_path)  # the default retry_for: 120 s
    assert code == 3
    assert 10.0 <= time.monotonic() - started < 20.0
    line = assert_failed(err, tmp_path / "outputs", f"127.0.0.1:{port}", "apiURL")
    assert "tried for 10 s" in line


def test_unknown_batch(capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator) -> None:
    unknown = uuid.uuid4()
    write_json(tmp_path / "inputs", batch_config(emu, batchID=str(unknown)))
    code, err = stook_run(capsys, tmp_path)
    assert code == 3
    assert_failed(err, tmp_path / "outputs", str(unknown), "404")


def test_broken_job_without_allowance(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, broken_emu: Emulator
) -> None:
    job = broken_emu.dataset.jobs(broken_emu.batch_id)[BROKEN]
    write_json(tmp_path / "inputs", batch_config(broken_emu))
    code, err = stook_run(capsys, tmp_path, toml=FAST_FETCH)
    assert code == 3
    assert_failed(err, tmp_path / "outputs", f"job {job.id}", "1 of 40 jobs missing")


# ---- 4: invalid metrics data ----


def test_corrupt_metrics_data_in_storage(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    with EmulatorThread(config(jobs_per_batch=40, seed=31)) as emu:
        victim = emu.dataset.jobs(emu.batch_id)[BROKEN]
        original = emu.dataset.job_output

        def corrupt(batch_id: uuid.UUID, job_id: uuid.UUID) -> MetricsOutput | None:
            output = original(batch_id, job_id)
            if output is None or job_id != victim.id:
                return output
            items = tuple(
                dataclasses.replace(d, body=b"\xff" * 24) if d.name == "speeds" else d
                for d in output.data
            )
            return dataclasses.replace(output, data=items, _data_index={d.id: d for d in items})

        monkeypatch.setattr(emu.dataset, "job_output", corrupt)
        write_json(tmp_path / "inputs", batch_config(emu))
        code, err = stook_run(capsys, tmp_path, toml=BATCH_TOML)
    assert code == 4
    assert_failed(err, tmp_path / "outputs", str(victim.id), "'speeds'")


def test_test_mode_output_that_breaks_a_platform_rule(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    (tmp_path / "inputs" / "experience").mkdir(parents=True)
    (tmp_path / "inputs" / "logs").mkdir()
    toml = '[test]\nmetrics = "tests.e2e.user_metrics:unset_status"\n'
    code, err = stook_run(capsys, tmp_path, toml=toml)
    assert code == 4
    assert_failed(err, tmp_path / "outputs", "'Broken scalar'", "status")


# ---- 0: missing jobs within the allowance ----


def test_broken_job_within_the_allowance(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, broken_emu: Emulator
) -> None:
    job = broken_emu.dataset.jobs(broken_emu.batch_id)[BROKEN]
    write_json(tmp_path / "inputs", batch_config(broken_emu))
    code, err = stook_run(
        capsys, tmp_path, "--allow-missing-jobs", "0.2", toml=FAST_FETCH + BATCH_TOML
    )
    assert code == 0, err
    assert failure_lines(err) == []
    outputs = tmp_path / "outputs"
    assert outputs_left(outputs) == [OUTPUT_NAME]
    view = read_output(outputs / OUTPUT_NAME)
    missing = by_name(view)["Missing jobs"]
    assert missing.type is MetricType.TEXT
    assert str(job.id) in text_of(missing)
    assert job.experience.name in text_of(missing)
    assert "1 of 40 jobs" in text_of(missing)
    assert missing.status is MetricStatus.FAIL_WARN
    assert view.status in (MetricStatus.FAIL_WARN, MetricStatus.FAIL_BLOCK)
    # Everything else is computed from the 39 other jobs.
    assert_matches_truth(view, expected_from_truth(broken_emu, skip_jobs=(BROKEN,)))


# ---- the real process ----


def _stook_command() -> list[str]:
    script = Path(sys.executable).parent / "stook"
    if script.exists():
        return [str(script)]
    return [sys.executable, "-c", "from stook.service.cli import main; main()"]


@pytest.mark.parametrize(
    ("case", "code"), [("bad-json", 2), ("wrong-token", 3), ("user-raises", 1), ("ok", 0)]
)
def test_the_process_exit_status(tmp_path: Path, emu: Emulator, case: str, code: int) -> None:
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    argv = [*_stook_command(), "run", "--inputs", str(inputs), "--outputs", str(outputs)]
    if case == "bad-json":
        write_json(inputs, "{")
    elif case == "wrong-token":
        write_json(inputs, batch_config(emu, authToken="not-the-emulator-token"))
    elif case == "user-raises":
        (inputs / "logs").mkdir(parents=True)
        (tmp_path / "stook.toml").write_text('[test]\nmetrics = "tests.e2e.user_metrics:raises"\n')
    else:
        write_json(inputs, batch_config(emu))
    env = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}
    env["PYTHONPATH"] = str(REPO)
    # cwd holds stook.toml in the user-raises case: ./stook.toml is read when present.
    done = subprocess.run(
        argv, cwd=tmp_path, env=env, capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == code, done.stderr
    errors = failure_lines(done.stderr)
    if code == 0:
        assert errors == []
        read_output(outputs / OUTPUT_NAME)
        return
    assert len(errors) == 1, done.stderr
    assert outputs_left(outputs) == []
    if case == "user-raises":
        # The user's traceback, down to their own frame, and nothing of stook's machinery.
        shown = traceback_text(done.stderr)
        assert "Traceback (most recent call last)" in shown
        assert "_lane_model_step" in shown
        assert "RuntimeError: lane model diverged on experience" in shown
    else:
        assert "Traceback" not in done.stderr


@pytest.mark.parametrize(
    ("case", "named"),
    [
        ("empty-file", ("batch_metrics_config.json", "not valid JSON")),
        ("json-list", ("batch_metrics_config.json", "JSON object")),
        ("ftp-url", ("batch_metrics_config.json", "'apiURL'")),
        ("no-project", ("batch_metrics_config.json", "'projectID'", "--project-id")),
        ("no-inputs-folder", ("inputs folder", "does not exist")),
        ("histogram-bounds", ("stook.toml", "[[batch.histogram]] #1")),
        ("zero-concurrency", ("stook.toml", "[fetch] concurrency")),
        ("share-above-one", ("--allow-missing-jobs", "1.5")),
    ],
)
def test_more_bad_inputs(
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    emu: Emulator,
    case: str,
    named: tuple[str, ...],
) -> None:
    inputs = tmp_path / "inputs"
    body: object = batch_config(emu)
    toml: str | None = None
    extra: list[str] = []
    if case == "empty-file":
        body = ""
    elif case == "json-list":
        body = [batch_config(emu)]
    elif case == "ftp-url":
        body = batch_config(emu, apiURL="ftp://127.0.0.1/v1")
    elif case == "no-project":
        assert isinstance(body, dict)
        del body["projectID"]
    elif case == "histogram-bounds":
        toml = BATCH_TOML.replace("upper = 40.0", "upper = 0.0")
    elif case == "zero-concurrency":
        toml = "[fetch]\nconcurrency = 0\n"
    elif case == "share-above-one":
        extra = ["--allow-missing-jobs", "1.5"]
    if case != "no-inputs-folder":
        write_json(inputs, body)
    before = emu.stats.requests["api"]
    code, err = stook_run(capsys, tmp_path, *extra, toml=toml)
    assert code == 2, err
    assert_failed(err, tmp_path / "outputs", *named)
    assert emu.stats.requests["api"] == before  # refused before any fetching
