"""What a person expects of a command line: text errors off `stook run`, one output flag
spelt one way (its other spellings kept as aliases), no traceback when the reader of
stdout goes away, no colours under NO_COLOR."""

from __future__ import annotations

import os
import re
import subprocess
import sys
import uuid
from pathlib import Path

import pytest

from stook.sdk import MetricsWriter
from stook.service.cli import build_parser
from stook.service.cli._main import EXIT_BROKEN_PIPE

CLI = [sys.executable, "-c", "from stook.service.cli import main; main()"]
# The environment of a person's shell: no STOOK_* settings of the test run's own.
ENV = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}


def _stook(*argv: str, **env: str) -> subprocess.CompletedProcess[str]:
    # stderr is a pipe, not a terminal, as under `2>&1 | cat` or in CI.
    return subprocess.run(
        [*CLI, *argv], capture_output=True, text=True, timeout=120, env={**ENV, **env}
    )


@pytest.mark.parametrize(
    "argv",
    [
        ["preview", "missing.binproto"],
        ["show", "missing.binproto"],
        ["validate", "missing.binproto"],
        ["metrics-config", "check", "missing.resim.yml"],
        ["metrics-config", "eval", "missing.resim.yml", "--emissions", "e", "--level", "test"],
    ],
)
def test_offline_commands_say_a_failure_as_text_off_a_terminal(argv: list[str]) -> None:
    done = _stook(*argv)
    assert done.returncode == 2
    (line,) = done.stderr.splitlines()
    assert line.startswith(("stook: error: ", "missing.resim.yml")), line
    assert not line.startswith("{")


def test_run_logs_json_lines_off_a_terminal_and_text_when_asked(tmp_path: Path) -> None:
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    (inputs / "batch_metrics_config.json").write_text("{not json")
    argv = ["run", "--inputs", str(inputs), "--output", str(tmp_path / "out")]
    done = _stook(*argv)
    assert done.returncode == 2
    assert done.stderr.splitlines()[-1].startswith("{")  # the platform collects JSON lines
    done = _stook(*argv, "--log-format", "console")
    assert done.returncode == 2
    assert done.stderr.splitlines()[-1].startswith("stook: error: ")
    done = _stook(*argv[:-2], "--outputs", str(tmp_path / "out"), STOOK_LOG_FORMAT="json")
    assert done.stderr.splitlines()[-1].startswith("{")


# Each command's output flag: -o/--output, and the spellings it had before as aliases.
OUTPUT_FLAGS = [
    (["run"], "outputs", ("-o", "--output", "--outputs")),
    (["demo"], "output", ("-o", "--output", "--outputs")),
    (["bench"], "out", ("-o", "--output", "--out")),
    (["preview", "f.binproto"], "output", ("-o", "--output", "--out")),
    (
        ["metrics-config", "eval", "c.yml", "--emissions", "e", "--level", "test"],
        "outputs",
        ("-o", "--output", "--outputs"),
    ),
]


@pytest.mark.parametrize(("command", "dest", "flags"), OUTPUT_FLAGS)
def test_every_output_flag_is_output_with_its_old_spellings_as_aliases(
    command: list[str], dest: str, flags: tuple[str, ...]
) -> None:
    parser = build_parser()
    for flag in flags:
        args = parser.parse_args([*command, flag, "somewhere"])
        assert str(getattr(args, dest)) == "somewhere", flag


def test_metrics_config_eval_reads_one_path_per_emissions_flag_and_report_as_dashboard() -> None:
    parser = build_parser()
    args = parser.parse_args(
        ["metrics-config", "eval", "--emissions", "runs/", "config.yml", "--level", "report"]
    )
    # The config after --emissions is the config, not a second emissions path.
    assert [str(p) for p in args.configs] == ["config.yml"]
    assert [str(p) for p in args.emissions] == ["runs"]
    assert args.level == "dashboard"  # report mode's metrics are the dashboard's
    args = parser.parse_args(
        [
            "metrics-config",
            "eval",
            "c.yml",
            "--emissions",
            "a",
            "--emissions",
            "b",
            "--level",
            "test",
        ]
    )
    assert [str(p) for p in args.emissions] == ["a", "b"]
    with pytest.raises(SystemExit):
        parser.parse_args(["metrics-config", "eval", "c.yml", "--emissions", "a", "--level", "x"])


def test_a_reader_that_goes_away_ends_show_quietly(tmp_path: Path) -> None:
    # `stook show FILE | head -1`: the reader stops reading; no error, no traceback.
    writer = MetricsWriter(uuid.UUID(int=7), deterministic=True)
    for i in range(2_000):  # more lines than a pipe buffers, so that a write fails
        writer.scalar(f"scalar {i:04}", float(i))
    path = writer.write(tmp_path / "metrics.binproto")
    for argv in (["show", str(path)], ["validate", str(path)]):
        read, write = os.pipe()
        os.close(read)  # the reader is gone before the first line
        try:
            done = subprocess.run(
                [*CLI, *argv], stdout=write, stderr=subprocess.PIPE, text=True, timeout=120
            )
        finally:
            os.close(write)
        assert done.returncode == EXIT_BROKEN_PIPE, done.stderr
        assert done.stderr == ""


def test_no_color_turns_colours_off_in_log_lines(monkeypatch: pytest.MonkeyPatch) -> None:
    import io

    import structlog

    from stook.service.modes import configure_logging

    class Terminal(io.StringIO):
        def isatty(self) -> bool:
            return True

    for no_color, coloured in (("", True), ("1", False)):
        monkeypatch.setenv("NO_COLOR", no_color)
        stream = Terminal()
        configure_logging(json=False, level="info", stream=stream)
        structlog.get_logger("t").info("hello", answer=42)
        assert ("\x1b[" in stream.getvalue()) is coloured
    # A short time of day (HH:MM:SS), not a 27-character ISO stamp, so that lines fit.
    line = stream.getvalue().splitlines()[0]
    assert re.match(r"\d\d:\d\d:\d\d ", line), line
