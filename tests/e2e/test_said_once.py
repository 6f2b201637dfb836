"""Each failure is said exactly once: one JSON event when logging JSON lines, one
``stook: error:`` line otherwise, for `stook run`, `validate` and `show` alike.

Every case runs the CLI in both formats and counts the stderr lines that carry the
failure's text. In JSON mode every stderr line must also parse as JSON, so that a log
pipeline reading the lines reads all of them.
"""

from __future__ import annotations

import json
import uuid
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path

import pytest

from stook.emulator import Emulator
from stook.sdk import MetricsWriter
from stook.service.cli import run_cli
from tests.e2e.support import EmulatorThread, config, outputs_left, write_batch_inputs
from tests.e2e.test_exit_codes import FAST_FETCH
from tests.failures import failure_lines

BROKEN = 3


# No ./stook.toml and no STOOK_* settings from the environment (tests/e2e/conftest.py).
pytestmark = pytest.mark.usefixtures("isolated")


@pytest.fixture(scope="module")
def emu() -> Iterator[Emulator]:
    with EmulatorThread(config(jobs_per_batch=20, seed=71, broken_jobs=(BROKEN,))) as emulator:
        yield emulator


@dataclass(frozen=True)
class Case:
    """A failing command: its argv (given the test's folder), its exit code, and a piece
    of text that only the report of the failure carries."""

    argv: Callable[[Path, Emulator], list[str]]
    code: int
    text: str


def _run(tmp: Path, *extra: str) -> list[str]:
    return ["run", "--inputs", str(tmp / "inputs"), "--outputs", str(tmp / "outputs"), *extra]


def _bad_json(tmp: Path, emu: Emulator) -> list[str]:
    (tmp / "inputs").mkdir()
    (tmp / "inputs" / "batch_metrics_config.json").write_text('{"authToken": ')
    return _run(tmp)


def _wrong_token(tmp: Path, emu: Emulator) -> list[str]:
    write_batch_inputs(tmp / "inputs", emu, token="not-the-emulator-token")
    return _run(tmp)


def _user_raises(tmp: Path, emu: Emulator) -> list[str]:
    (tmp / "inputs" / "logs").mkdir(parents=True)
    (tmp / "stook.toml").write_text('[test]\nmetrics = "tests.e2e.user_metrics:raises"\n')
    return _run(tmp, "--config", str(tmp / "stook.toml"))


def _garbage_file(tmp: Path, emu: Emulator) -> list[str]:
    (tmp / "garbage.binproto").write_bytes(b"\xff\xff\xff\xff")
    return ["validate", str(tmp / "garbage.binproto")]


def _invalid_file(tmp: Path, emu: Emulator) -> list[str]:
    writer = MetricsWriter(uuid.UUID(int=5), deterministic=True)
    writer.scalar("broken", 1.0).proto.status = 0  # type: ignore[assignment]
    writer.write(tmp / "invalid.binproto", validate=False)
    return ["validate", str(tmp / "invalid.binproto")]


def _missing_file(tmp: Path, emu: Emulator) -> list[str]:
    return ["show", str(tmp / "nowhere.binproto")]


CASES = {
    "bad inputs JSON": Case(_bad_json, 2, "not valid JSON"),
    "wrong token": Case(_wrong_token, 3, "refused the token"),
    "user function raises": Case(_user_raises, 1, "user_metrics:raises raised"),
    "validate garbage": Case(_garbage_file, 4, "not a valid protobuf message"),
    "validate an invalid file": Case(_invalid_file, 4, "the metric status is unset"),
    "show a missing file": Case(_missing_file, 2, "no such file"),
}


def _run_cli(argv: list[str], log_format: str, monkeypatch: pytest.MonkeyPatch) -> int:
    if argv[0] == "run":
        return run_cli([*argv, "--log-format", log_format])
    # validate and show have no logging flags; they follow STOOK_LOG_FORMAT.
    monkeypatch.setenv("STOOK_LOG_FORMAT", log_format)
    return run_cli(argv)


def assert_said_once(err: str, text: str, log_format: str) -> None:
    carrying = [line for line in err.splitlines() if text in line]
    assert len(carrying) == 1, f"{text!r} said {len(carrying)} times:\n{err}"
    assert len(failure_lines(err)) == 1, err
    if log_format == "json":
        for line in err.splitlines():
            assert isinstance(json.loads(line), dict), line
        assert json.loads(carrying[0])["event"] == "stook failed"
    else:
        assert carrying[0].startswith("stook: error: ")
        assert not any(line.startswith("{") for line in err.splitlines()), err


@pytest.mark.parametrize("log_format", ["json", "console"])
@pytest.mark.parametrize("case", CASES.values(), ids=CASES.keys())
def test_a_failure_is_said_once(
    case: Case,
    log_format: str,
    emu: Emulator,
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    argv = case.argv(tmp_path, emu)
    code = _run_cli(argv, log_format, monkeypatch)
    err = capsys.readouterr().err
    assert code == case.code, err
    assert_said_once(err, case.text, log_format)


@pytest.mark.parametrize("log_format", ["json", "console"])
def test_an_unavailable_job_is_said_once_and_the_final_line_sums_up(
    log_format: str, emu: Emulator, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_batch_inputs(tmp_path / "inputs", emu)
    (tmp_path / "stook.toml").write_text(FAST_FETCH)
    argv = _run(tmp_path, "--config", str(tmp_path / "stook.toml"), "--log-format", log_format)
    code = run_cli(argv)
    err = capsys.readouterr().err
    assert code == 3, err
    job = emu.dataset.jobs(emu.batch_id)[BROKEN]
    # The reason is in the job's warning only; the final line names the job and counts.
    reason = [line for line in err.splitlines() if "failed after" in line]
    assert len(reason) == 1, err
    assert "job unavailable" in reason[0]
    (final,) = failure_lines(err)
    assert f"job {job.id}" in final
    assert "1 of 20 jobs missing" in final
    assert "failed after" not in final
    assert outputs_left(tmp_path / "outputs") == []
