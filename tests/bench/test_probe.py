"""`stook bench --probe`: the recommendation, what it writes, and its bad inputs.

The probe's levels against the emulator's concurrency limit are in test_probe_emulator.py
(slow); here the rules are checked on levels made by hand, and the command on an emulator
in its own process, at levels too short to mean anything.
"""

from __future__ import annotations

import csv
import json
import os
import signal
import socket
import subprocess
import sys
import tomllib
from collections.abc import Iterator
from pathlib import Path

import pytest
import structlog

from stook.bench._probe_level import LevelResult, OriginResult, percentile
from stook.bench._probe_results import (
    ProbeResult,
    fetch_lines,
    recommend,
    stops_climb,
    write_results,
)
from stook.emulator import EmulatorConfig, EmulatorProcess, Outage
from stook.service.cli import run_cli


def origin(p95: float | None = None, **counts: int) -> OriginResult:
    return OriginResult(
        requests=counts.get("requests", 100),
        answered=counts.get("requests", 100),
        p50_ms=None if p95 is None else p95 / 2,
        p95_ms=p95,
        p99_ms=None if p95 is None else p95 * 1.5,
        throttled=counts.get("throttled", 0),
        server_errors=counts.get("server_errors", 0),
        retries=0,
        failed=0,
    )


def level(
    concurrency: int, rps: float, p95: float = 20.0, *, throttled: int = 0, errors: int = 0
) -> LevelResult:
    return LevelResult(
        concurrency=concurrency,
        seconds=1.0,
        requests_per_s=rps,
        p50_ms=p95 / 2,
        p95_ms=p95,
        p99_ms=p95 * 1.5,
        throttled=throttled,
        errors=errors,
        retries=0,
        requests=1000,
        api=origin(p95, throttled=throttled),
        storage=origin(p95),
    )


def test_the_recommendation_is_where_throughput_stops_growing() -> None:
    levels = [level(4, 100), level(8, 200), level(16, 390), level(32, 400), level(64, 405)]
    assert recommend(levels) == 16


def test_a_throttled_level_is_never_recommended_nor_its_throughput_the_best() -> None:
    levels = [level(4, 100), level(8, 200), level(16, 300), level(32, 900, throttled=40)]
    assert stops_climb(levels[-1]) is not None
    assert recommend(levels) == 16


def test_a_level_whose_p95_more_than_doubled_is_passed_over() -> None:
    levels = [level(4, 380, p95=10.0), level(8, 400, p95=25.0), level(16, 400, p95=19.0)]
    assert recommend(levels) == 4  # within 10 % of the best already, and calm
    levels = [level(4, 200, p95=10.0), level(8, 400, p95=25.0), level(16, 400, p95=19.0)]
    assert recommend(levels) == 16


def test_the_best_throughput_is_that_of_the_levels_whose_p95_has_not_doubled() -> None:
    levels = [level(4, 200, p95=10.0), level(8, 300, p95=18.0), level(16, 400, p95=45.0)]
    assert recommend(levels) == 8


def test_errors_above_a_few_percent_stop_the_climb() -> None:
    assert stops_climb(level(8, 100, errors=20)) is None  # 2 % of 1,000
    assert "errors at concurrency 8" in (stops_climb(level(8, 100, errors=50)) or "")


def test_nothing_is_recommended_when_the_lowest_level_is_throttled() -> None:
    result = ProbeResult("batch", (level(4, 100, throttled=3),), recommend([]), "throttled")
    assert result.recommended_concurrency is None
    assert recommend([level(4, 100, throttled=3)]) is None
    assert tomllib.loads(fetch_lines(result)) == {"fetch": {}}


def test_percentiles_are_nearest_rank() -> None:
    values = [float(v) for v in range(1, 101)]
    assert percentile(values, 0.50) == 50.0
    assert percentile(values, 0.95) == 95.0
    assert percentile(values, 0.99) == 99.0
    assert percentile([7.0], 0.99) == 7.0
    assert percentile([], 0.5) is None


def test_the_results_are_written_as_json_csv_and_toml(tmp_path: Path) -> None:
    levels = (level(4, 100), level(8, 200), level(16, 390), level(32, 400, throttled=9))
    result = ProbeResult("batch", levels, recommend(levels), stops_climb(levels[-1]))
    written = write_results(result, tmp_path, plot=False)
    assert [p.name for p in written] == ["probe.json", "probe.csv"]
    doc = json.loads((tmp_path / "probe.json").read_text())
    assert doc["recommended_concurrency"] == 16
    keys = {"concurrency", "requests_per_s", "p50_ms", "p95_ms", "p99_ms", "throttled", "errors"}
    assert all(keys <= set(entry) for entry in doc["levels"])
    assert [entry["concurrency"] for entry in doc["levels"]] == [4, 8, 16, 32]
    assert doc["levels"][3]["throttled"] == 9
    assert doc["levels"][0]["api"]["p95_ms"] == 20.0
    with (tmp_path / "probe.csv").open() as file:
        rows = list(csv.DictReader(file))
    assert [row["concurrency"] for row in rows] == ["4", "8", "16", "32"]
    assert rows[2]["requests_per_s"] == "390"
    assert tomllib.loads(fetch_lines(result)) == {"fetch": {"concurrency": 16}}


# ---- the command ----


@pytest.fixture(autouse=True)
def _fresh_structlog() -> Iterator[None]:
    # run_cli points structlog at capsys's stderr; later tests must not write to it.
    structlog.reset_defaults()
    yield
    structlog.reset_defaults()


# Small pages, so that listings take several.
SMALL = EmulatorConfig(jobs_per_batch=20, seed=31, default_page_size=5, max_page_size=8)


@pytest.fixture(scope="module")
def emu() -> Iterator[EmulatorProcess]:
    with EmulatorProcess(SMALL) as emulator:
        yield emulator


def write_batch_inputs(
    inputs: Path, emu: EmulatorProcess, *, token: str | None = None, api_url: str | None = None
) -> None:
    inputs.mkdir(parents=True, exist_ok=True)
    body = emu.info.batch_config() | {
        "authToken": token or emu.token,
        "apiURL": api_url or emu.api_url,
    }
    (inputs / "batch_metrics_config.json").write_text(json.dumps(body))


def stook_command() -> list[str]:
    script = Path(sys.executable).parent / "stook"
    if script.exists():
        return [str(script)]
    return [sys.executable, "-c", "from stook.service.cli import main; main()"]


def probe_cli(
    capsys: pytest.CaptureFixture[str], tmp: Path, *extra: str, toml: str = ""
) -> tuple[int, str, str]:
    (tmp / "stook.toml").write_text(toml)
    argv = ["bench", "--probe", "--inputs", str(tmp / "inputs"), "--out", str(tmp / "out")]
    code = run_cli([*argv, "--config", str(tmp / "stook.toml"), "--log-format", "json", *extra])
    out, err = capsys.readouterr()
    return code, out, err


def failure_lines(err: str) -> list[str]:
    return [line for line in err.splitlines() if '"level": "error"' in line]


def test_a_short_probe_writes_its_results_and_the_fetch_lines(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: EmulatorProcess
) -> None:
    write_batch_inputs(tmp_path / "inputs", emu)
    toml = '[[batch.histogram]]\nname = "Speeds"\ndata = "speeds"\nlower = 0.0\nupper = 40.0\n'
    code, out, err = probe_cli(
        capsys, tmp_path, "--levels", "1,2", "--max-requests", "30", toml=toml
    )
    assert code == 0, err
    doc = json.loads((tmp_path / "out" / "probe.json").read_text())
    assert [entry["concurrency"] for entry in doc["levels"]] == [1, 2]
    for entry in doc["levels"]:
        # The request cap holds, but for the calls in flight when it was reached (and their
        # listings' further pages: the test emulator's pages are small).
        assert 30 <= entry["requests"] <= 30 + 4 * entry["concurrency"]
        assert entry["storage"]["answered"] > 0  # the histogram's data is downloaded
    assert doc["recommended_concurrency"] in (1, 2)
    assert (tmp_path / "out" / "probe.csv").is_file()
    assert "recommended concurrency" in out
    fetch = out[out.index("[fetch]") :]
    assert tomllib.loads(fetch)["fetch"]["concurrency"] == doc["recommended_concurrency"]
    assert emu.token not in out + err


def test_a_report_is_probed_with_report_mode_s_requests(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: EmulatorProcess
) -> None:
    emu.write_report_config(tmp_path / "inputs")
    code, out, err = probe_cli(capsys, tmp_path, "--levels", "2", "--max-requests", "20")
    assert code == 0, err
    doc = json.loads((tmp_path / "out" / "probe.json").read_text())
    assert doc["kind"] == "report"
    (only,) = doc["levels"]
    assert 0 < only["api"]["answered"] <= only["requests"]
    assert 20 <= only["requests"] <= 20 + 4 * 2
    assert "(report mode)" in out


def test_no_config_in_the_inputs_is_exit_2_before_any_request(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    (tmp_path / "inputs").mkdir()
    code, out, err = probe_cli(capsys, tmp_path)
    assert code == 2
    (line,) = failure_lines(err)
    assert "batch_metrics_config.json" in line
    assert not (tmp_path / "out").exists()
    assert out == ""


def test_a_bad_token_is_exit_3_at_the_first_request(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: EmulatorProcess
) -> None:
    wrong = "wrong-token-for-the-probe"
    write_batch_inputs(tmp_path / "inputs", emu, token=wrong)
    code, out, err = probe_cli(capsys, tmp_path)
    assert code == 3
    (line,) = failure_lines(err)
    assert "401" in line
    assert wrong not in out + err
    assert not (tmp_path / "out" / "probe.json").exists()


def test_an_unreachable_api_is_exit_3_within_the_retry_budget(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: EmulatorProcess
) -> None:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        port = sock.getsockname()[1]
    write_batch_inputs(tmp_path / "inputs", emu, api_url=f"http://127.0.0.1:{port}/v1")
    code, _, err = probe_cli(capsys, tmp_path, toml="[fetch]\nretry_for = 1\ntimeout = 1.0\n")
    assert code == 3
    (line,) = failure_lines(err)
    assert f"127.0.0.1:{port}" in line


@pytest.mark.parametrize(
    ("flag", "value"),
    [("--levels", "4,x"), ("--levels", "8,8"), ("--levels", "0,4"), ("--seconds-per-level", "0")],
)
def test_bad_flags_are_exit_2(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, flag: str, value: str
) -> None:
    (tmp_path / "inputs").mkdir()
    with pytest.raises(SystemExit) as exit_:
        probe_cli(capsys, tmp_path, flag, value)
    assert exit_.value.code == 2


@pytest.mark.parametrize(
    "argv",
    [["bench", "--levels", "4,8"], ["bench", "--inputs", "x"], ["bench", "--probe", "--quick"]],
)
def test_probe_flags_without_probe_are_exit_2(
    capsys: pytest.CaptureFixture[str], argv: list[str]
) -> None:
    assert run_cli([*argv, "--log-format", "json"]) == 2
    (line,) = failure_lines(capsys.readouterr().err)
    assert "--probe" in line


@pytest.mark.slow  # a process of its own: a few seconds on a busy machine
def test_ctrl_c_writes_and_prints_the_levels_measured_so_far(tmp_path: Path) -> None:
    # After its first level's 30 requests and the listing, the API is down for a minute:
    # the second level retries until SIGINT ends it.
    outage = Outage(origin="api", after_requests=40, duration_s=60)
    with EmulatorProcess(SMALL.replace(outages=(outage,))) as emulator:
        write_batch_inputs(tmp_path / "inputs", emulator)
        (tmp_path / "stook.toml").write_text("")
        argv = [*stook_command(), "bench", "--probe", "--inputs", str(tmp_path / "inputs")]
        argv += ["--config", str(tmp_path / "stook.toml"), "--out", str(tmp_path / "out")]
        argv += ["--levels", "1,2", "--max-requests", "30", "--seconds-per-level", "30"]
        env = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}
        with subprocess.Popen(
            [*argv, "--log-format", "json", "--log-level", "info"],
            env=env,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        ) as proc:
            assert proc.stderr is not None
            said: list[str] = []
            for line in proc.stderr:  # until the first level is measured
                said.append(line)
                if '"probe level"' in line:
                    break
            else:
                pytest.fail("".join(said))
            proc.send_signal(signal.SIGINT)
            out, err = proc.communicate(timeout=10)
    assert proc.returncode == 130, "".join(said) + err
    assert [line for line in err.splitlines() if '"stook interrupted"' in line]
    doc = json.loads((tmp_path / "out" / "probe.json").read_text())
    assert doc["interrupted"] is True
    assert [entry["concurrency"] for entry in doc["levels"]] == [1]
    # What was measured is shown, but a climb cut short recommends nothing to paste.
    assert doc["recommended_concurrency"] is None
    assert "interrupted" in out
    assert "recommends no concurrency" in out
    assert "paste into stook.toml" not in out
    assert "concurrency = " not in out
