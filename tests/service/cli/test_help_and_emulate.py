"""Every command's --help says what each argument is and matches the docs; `show --full`;
`stook emulate`'s first-class knobs, --host / --public-host and the report config."""

from __future__ import annotations

import argparse
import json
import re
import subprocess
import sys
import time
import urllib.request
import uuid
from pathlib import Path

import pytest

from stook.emulator import Emulator, EmulatorConfig
from stook.emulator._cli import settings_from
from stook.sdk import MetricsWriter
from stook.service.cli import build_parser, run_cli
from stook.service.modes import ConfigError

CLI = [sys.executable, "-c", "from stook.service.cli import main; main()"]
CLI_PAGE = Path(__file__).resolve().parents[3] / "docs" / "cli.md"


def _commands() -> dict[str, argparse.ArgumentParser]:
    parser = build_parser()
    (sub,) = [a for a in parser._actions if isinstance(a, argparse._SubParsersAction)]
    return {"stook": parser, **sub.choices}


def _help(*command: str) -> str:
    done = subprocess.run(
        [*CLI, *command, "--help"], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.parametrize("name", sorted(_commands()))
def test_every_argument_of_every_command_says_what_it_is(name: str) -> None:
    command = _commands()[name]
    for action in command._actions:
        if isinstance(action, argparse._SubParsersAction):
            assert all(c.help for c in action._choices_actions)
            continue
        assert action.help, f"stook {name}: {action.dest} has no help"
    if name != "stook":
        assert command.description, f"stook {name} has no description"
    text = command.format_help()
    for action in command._actions:
        for option in action.option_strings:
            assert option in text
        if action.option_strings and action.default not in (None, False, [], "==SUPPRESS=="):
            shown = command._get_formatter()._get_help_string(action)
            assert "default" in (shown or ""), f"stook {name}: {action.dest} hides its default"


@pytest.mark.parametrize("name", sorted(_commands()))
def test_each_command_is_parsed_as_by_the_whole_command_line(
    name: str, capsys: pytest.CaptureFixture[str]
) -> None:
    # `stook` builds only the arguments of the command it runs: its help, and the top
    # level's, are those of the whole command line.
    command = [] if name == "stook" else [name]
    with pytest.raises(SystemExit):
        build_parser().parse_args([*command, "--help"])
    whole = capsys.readouterr().out
    with pytest.raises(SystemExit) as done:
        run_cli([*command, "--help"])
    assert done.value.code == 0
    assert capsys.readouterr().out == whole


def test_a_bare_stook_shows_the_help(capsys: pytest.CaptureFixture[str]) -> None:
    # As git, uv and ruff do: not an error, the list of commands.
    assert run_cli([]) == 0
    out, err = capsys.readouterr()
    assert out.startswith("usage: stook")
    assert "metrics-config" in out
    assert err == ""


def test_an_unknown_command_or_choice_is_refused_with_the_nearest_one(
    capsys: pytest.CaptureFixture[str],
) -> None:
    for argv, error in (
        (["valdiate", "x.binproto"], "invalid choice: 'valdiate'"),
        (["runn"], "invalid choice: 'runn'"),
        (["--log-level", "info", "validate", "x.binproto"], "invalid choice: 'info'"),
        (["metrics-config", "chek", "c.yml"], "invalid choice: 'chek'"),
        (["run", "--log-format", "jsn"], "invalid choice: 'jsn'"),
    ):
        with pytest.raises(SystemExit) as done:
            run_cli(argv)
        assert done.value.code == 2
        err = capsys.readouterr().err
        assert error in err
        suggestion = {"valdiate": "validate", "runn": "run", "chek": "check", "jsn": "json"}
        nearest = next((v for k, v in suggestion.items() if k in error), None)
        if nearest:
            assert f"did you mean {nearest!r}?" in err
        else:
            assert "did you mean" not in err  # 'info' is near no command


def test_run_help_has_the_docs_exit_codes_and_mode_detection() -> None:
    text = _help("run")
    page = CLI_PAGE.read_text(encoding="utf-8")
    table = page[page.index("### Exit codes") :].split("\n\n", 2)[1]
    codes = re.findall(r"^\| ([\d, ]+) \|", table, re.M)
    assert codes == ["0", "1", "2", "3", "4", "5", "130, 143"]
    epilog = text[text.index("exit codes:") :]
    for code in codes:
        assert re.search(rf"^  {code} ", epilog, re.M), code
    for name in ("report_config.json", "batch_metrics_config.json", "experience/, logs/"):
        assert name in text
    flat = " ".join(text.split())
    for default in ("/tmp/resim/inputs", "/tmp/resim/outputs", "./stook.toml"):
        assert f"default {default}" in flat
    for variable in (
        "STOOK_INPUTS",
        "STOOK_PROGRESS",
        "STOOK_PROGRESS_INTERVAL",
        "STOOK_EVENT_LOOP",
    ):
        assert variable in text


def test_defaults_are_shown_and_files_described() -> None:
    assert "(default: 200)" in _help("emulate")
    assert "(default: demo-output)" in _help("demo")
    assert "default warning" in _help("demo")  # its own log level, not run's
    for command in ("show", "validate"):
        text = _help(command)
        assert re.search(r"file\s+a metrics\.binproto", text)
        assert "exit codes: 0" in text


def test_show_full_prints_text_metrics_whole(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    long_name = "A metric name far longer than the table's fifty-six characters of width"
    body = "Regressions since batch 12:\n- Localization error: 0.31 m -> 0.62 m\n" + "x" * 90
    writer = MetricsWriter(uuid.UUID(int=5), deterministic=True)
    writer.text("Regressions", body)
    writer.scalar(long_name, 1.0)
    path = writer.write(tmp_path / "metrics.binproto")

    assert run_cli(["show", str(path)]) == 0
    short = capsys.readouterr().out
    assert "- Localization error" not in short
    assert long_name not in short
    assert run_cli(["show", "--full", str(path)]) == 0
    full = capsys.readouterr().out
    assert f"== Regressions ==\n{body}\n" in full
    assert long_name in full


# ---------------------------------------------------------------- emulate


def _status_and_body(request: urllib.request.Request) -> tuple[int, bytes]:
    try:
        with urllib.request.urlopen(request, timeout=10) as answer:
            return answer.status, answer.read()
    except urllib.error.HTTPError as error:
        return error.code, b""


def _settings(*flags: str) -> EmulatorConfig:
    return settings_from(build_parser().parse_args(["emulate", *flags]))


def test_emulate_faults_limits_and_broken_jobs_are_flags() -> None:
    config = _settings(
        "--fault-5xx",
        "0.05",
        "--fault-429",
        "0.02",
        "--fault-reset",
        "0.01",
        "--rate-limit",
        "50",
        "--storage-rate-limit",
        "200",
        "--broken-jobs",
        "3,17",
        "--latency-ms",
        "12",
    )
    assert (config.fault_5xx, config.fault_429, config.fault_reset) == (0.05, 0.02, 0.01)
    assert (config.rate_limit_rps, config.storage_rate_limit_rps) == (50, 200)
    assert config.broken_jobs == (3, 17)
    assert config.latency_ms == 12
    # --set still works, and still wins over a flag.
    assert _settings("--fault-5xx", "0.05", "--set", "fault_5xx=0.2").fault_5xx == 0.2
    assert _settings() == EmulatorConfig(seed=7, jobs_per_batch=200, report_batches=12)


@pytest.mark.parametrize(
    ("flags", "message"),
    [
        (["--broken-jobs", "3,x"], "--broken-jobs '3,x': expected indices such as 3,17"),
        (["--fault-5xx", "1.5"], "emulator settings: fault fractions must lie in [0, 1]"),
        (["--rate-limit", "-1"], "emulator settings: a rate limit must be positive"),
    ],
)
def test_a_bad_emulate_flag_is_named(flags: list[str], message: str) -> None:
    with pytest.raises(ConfigError, match="^" + re.escape(message)):
        _settings(*flags)


async def test_an_emulator_on_every_interface_hands_out_urls_clients_can_reach() -> None:
    async with Emulator(EmulatorConfig(jobs_per_batch=1), host="0.0.0.0") as emu:
        assert emu.api_url.startswith("http://127.0.0.1:")
        assert emu.storage_url.startswith("http://127.0.0.1:")
    named = Emulator(EmulatorConfig(jobs_per_batch=1), public_host="localhost")
    async with named as emu:
        assert emu.api_url.startswith("http://localhost:")
        assert emu.storage_url.startswith("http://localhost:")


@pytest.mark.slow
def test_emulate_serves_on_a_host_and_writes_both_configs(tmp_path: Path) -> None:
    inputs, report_inputs = tmp_path / "inputs", tmp_path / "report-inputs"
    proc = subprocess.Popen(
        [
            *CLI,
            "emulate",
            "--jobs",
            "4",
            "--batches",
            "3",
            "--host",
            "0.0.0.0",
            "--public-host",
            "localhost",
            "--fault-5xx",
            "0.1",
            "--inputs",
            str(inputs),
            "--report-inputs",
            str(report_inputs),
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
    )
    try:
        assert proc.stdout is not None
        seen: list[str] = []
        deadline = time.monotonic() + 30
        while not seen or "Press Ctrl-C" not in seen[-1]:
            assert time.monotonic() < deadline, seen
            line = proc.stdout.readline()
            assert line, f"emulator exited early: {seen}"
            seen.append(line.rstrip("\n"))
        text = "\n".join(seen)
        batch = json.loads((inputs / "batch_metrics_config.json").read_text())
        report = json.loads((report_inputs / "report_config.json").read_text())
        assert batch["apiURL"] == report["apiURL"]
        assert batch["apiURL"].startswith("http://localhost:")
        assert f"run:       stook run --inputs {inputs}" in text
        assert f"run:       stook run --inputs {report_inputs}" in text
        assert "listening: 0.0.0.0" in text
        assert "(3 batches)" in text
        request = urllib.request.Request(
            f"{report['apiURL']}/projects/{report['projectID']}/reports/{report['reportID']}",
            headers={"Authorization": f"Bearer {report['authToken']}"},
        )
        answers = [_status_and_body(request) for _ in range(3)]
        ok = [body for status, body in answers if status == 200]
        assert ok, answers  # at most two faults in a row (max_consecutive_faults)
        assert json.loads(ok[0])["reportID"] == report["reportID"]
        assert {status for status, _ in answers} <= {200, 500, 502, 503}
    finally:
        proc.terminate()
        proc.wait(timeout=15)
        if proc.stdout is not None:
            proc.stdout.close()
