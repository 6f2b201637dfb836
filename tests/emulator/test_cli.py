"""`stook emulate --set KEY=VALUE`: every emulator setting from the command line."""

from __future__ import annotations

import subprocess
import sys

import pytest

from stook.emulator import EmulatorConfig
from stook.emulator._cli import settings_from
from stook.service.cli import build_parser
from stook.service.modes import ConfigError
from tests.failures import failure_lines


def _settings(*extra: str) -> EmulatorConfig:
    return settings_from(build_parser().parse_args(["emulate", "--jobs", "9", *extra]))


def test_named_flags_then_every_set_in_order() -> None:
    config = _settings(
        "--set",
        "spec_quirks=true",
        "--set",
        'outages=[{"origin": "storage", "after_s": 5, "duration_s": 8}]',
        "--set",
        "token=short",  # not JSON: taken as a string
        "--set",
        "jobs_per_batch=4",  # a later --set wins over the named flag
    )
    assert config.spec_quirks is True
    assert [(o.origin, o.after_s, o.duration_s) for o in config.outages] == [("storage", 5, 8)]
    assert config.token == "short"
    assert config.jobs_per_batch == 4
    assert _settings().jobs_per_batch == 9


@pytest.mark.parametrize(
    ("item", "message"),
    [
        ("novalue", "--set 'novalue': expected KEY=VALUE"),
        ("=3", "--set '=3': expected KEY=VALUE"),
        ("nope=1", "emulator settings: unknown emulator settings: ['nope']"),
        ("fault_5xx=2", "emulator settings: fault fractions must lie in [0, 1]"),
        (
            'outages=[{"origin": "moon", "duration_s": 1}]',
            "emulator settings: outages[0].origin: invalid enum value 'moon'",
        ),
        # A value of the wrong type: named with the type wanted, not a Python TypeError.
        ("fault_5xx=abc", "emulator settings: fault_5xx: expected float, got str"),
        ("broken_jobs=[1, true]", "emulator settings: broken_jobs[1]: expected int, got bool"),
    ],
)
def test_a_bad_setting_is_named(item: str, message: str) -> None:
    with pytest.raises(ConfigError, match="^" + message.replace("[", r"\[").replace("(", r"\(")):
        _settings("--set", item)


def test_the_command_exits_2_with_one_line() -> None:
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            "from stook.service.cli import main; main()",
            "emulate",
            "--set",
            "nope=1",
            "--log-format",
            "console",
        ],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert failure_lines(done.stderr) == [
        "stook: error: emulator settings: unknown emulator settings: ['nope']"
    ]
