"""The job-data built-ins' tables (histogram by metric, category_totals, events, sweep, by_tag)
are checked before the first request: a bad table is exit 2, one line, no request, no output."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.emulator import Emulator
from stook.service.cli import run_cli
from tests.e2e.support import EmulatorThread, config, outputs_left, write_batch_inputs
from tests.failures import failure_lines

pytestmark = pytest.mark.usefixtures("isolated")


@pytest.fixture(scope="module")
def emu() -> Iterator[Emulator]:
    with EmulatorThread(config(jobs_per_batch=4, seed=3)) as emulator:
        yield emulator


BAD_TABLES = {
    "histogram with metric and data": (
        '[[batch.histogram]]\nname = "H"\nmetric = "Speed histogram"\ndata = "speeds"\n',
        "[[batch.histogram]] #1: give exactly one of 'data' (a double series) or 'metric'",
    ),
    "histogram with metric and bounds": (
        '[[batch.histogram]]\nname = "H"\nmetric = "Speed histogram"\nlower = 0\n',
        "[[batch.histogram]] #1: 'lower' cannot be given with 'metric': the buckets are the "
        "ones the jobs' histogram 'Speed histogram' used",
    ),
    "category_totals without a source": (
        '[[batch.category_totals]]\nname = "T"\n',
        "[[batch.category_totals]] #1: give exactly one of 'data' (per-category data) or 'metric'",
    ),
    "category_totals with both": (
        '[[batch.category_totals]]\ndata = "d"\nmetric = "m"\n',
        "[[batch.category_totals]] #1: give exactly one of 'data' (per-category data) or 'metric'",
    ),
    "category_totals typo": (
        '[[batch.category_totals]]\ndatum = "d"\n',
        "[[batch.category_totals]] #1: unknown key 'datum' "
        "(known: data, metric, name, x_axis_name, y_axis_name)",
    ),
    "events typo": (
        '[[batch.events]]\nnames = ["Collision"]\n',
        "[[batch.events]] #1: unknown key 'names' (known: name)",
    ),
    "sweep missing metrics": (
        '[[batch.sweep]]\nparameters = ["max_speed"]\n',
        "[[batch.sweep]] #1: missing key 'metrics'",
    ),
    "sweep parameters not a list": (
        '[[batch.sweep]]\nparameters = "max_speed"\nmetrics = ["Collisions"]\n',
        "[[batch.sweep]] #1: option 'parameters' cannot be 'max_speed' (expected Sequence)",
    ),
    "sweep no parameters": (
        '[[batch.sweep]]\nparameters = []\nmetrics = ["Collisions"]\n',
        "[[batch.sweep]] #1: 'parameters' must name at least one",
    ),
    "by_tag typo": (
        '[[batch.by_tag]]\nmetric = ["Collisions"]\n',
        "[[batch.by_tag]] #1: unknown key 'metric' (known: metrics, name)",
    ),
}


@pytest.mark.parametrize("case", list(BAD_TABLES))
def test_a_bad_table_is_exit_2_before_any_request(
    case: str, capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    toml, message = BAD_TABLES[case]
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    write_batch_inputs(inputs, emu)
    (tmp_path / "stook.toml").write_text(toml)
    before = emu.stats.requests["api"]
    argv = ["run", "--inputs", str(inputs), "--outputs", str(outputs)]
    code = run_cli([*argv, "--config", str(tmp_path / "stook.toml"), "--log-format", "json"])
    err = capsys.readouterr().err
    assert code == 2, err
    (line,) = failure_lines(err)
    assert line.endswith(message), line
    assert "Traceback" not in err
    assert emu.stats.requests["api"] == before
    assert outputs_left(outputs) == []
