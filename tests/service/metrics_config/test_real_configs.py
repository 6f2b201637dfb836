"""ReSim's own demo configs pass `check --strict`: every key they use is one stook reads.

The `resim-open-core` wheel's configs are read where the package is installed; the
`signalflag` 1.8.0 wheel's `session.resim.yml` is copied in `real_configs/` (its README
says why and under which licence)."""

from __future__ import annotations

import importlib.resources
from pathlib import Path

import pytest

from stook.service.cli._main import run_cli
from stook.service.metrics_config import load_config

REAL_CONFIGS = Path(__file__).parent / "real_configs"


def _wheel_data() -> Path:
    return Path(str(importlib.resources.files("resim.demo").joinpath("data")))


def _config(name: str) -> Path:
    """A demo config by name: `session.resim.yml` is the copy, the others the wheel's."""
    copied = REAL_CONFIGS / name
    return copied if copied.is_file() else _wheel_data() / name


@pytest.mark.parametrize("name", ["config.resim.yml", "mujoco.resim.yml", "session.resim.yml"])
def test_resims_demo_configs_pass_check_strictly(
    capsys: pytest.CaptureFixture[str], name: str
) -> None:
    code = run_cli(["metrics-config", "check", "--strict", str(_config(name))])
    captured = capsys.readouterr()
    assert captured.err == ""
    assert code == 0
    assert captured.out.endswith(" metrics, ok\n")


def test_the_demo_dashboards_are_read() -> None:
    config = load_config([_wheel_data() / "config.resim.yml"])
    (dashboard,) = config.dashboards.values()
    assert dashboard.metrics_set in config.metrics_sets
    assert dashboard.refresh == "auto"
    assert dashboard.day_range == 30
