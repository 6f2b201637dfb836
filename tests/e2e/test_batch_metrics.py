"""Batch mode end to end: every metric of the output against the emulator's ground truth."""

from __future__ import annotations

from pathlib import Path

import pytest

from stook.service.cli._run import RunOptions, run
from stook.testing import emulated_batch
from tests.e2e.support import (
    BATCH_TOML,
    OUTPUT_NAME,
    assert_matches_truth,
    by_name,
    expected_from_truth,
    outputs_left,
    read_output,
)


# With spec_quirks the API answers as the spec allows (fields left out, values listed as
# null, unknown enum values, unnamed data, nanosecond timestamps): the same metrics.
# Byte-identical to the clean output (test_spec_answers.py, quick); compared with the
# independent computation again in the slow tier.
@pytest.mark.parametrize(
    "spec_quirks", [False, pytest.param(True, marks=pytest.mark.slow)], ids=["clean", "spec-quirks"]
)
async def test_every_batch_metric_equals_an_independent_computation(
    tmp_path: Path, spec_quirks: bool
) -> None:
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    toml = tmp_path / "stook.toml"
    toml.write_text(BATCH_TOML)
    async with emulated_batch(inputs, jobs_per_batch=90, seed=11, spec_quirks=spec_quirks) as emu:
        written = await run(RunOptions(inputs=inputs, outputs=outputs, config=toml))
        assert written == outputs / OUTPUT_NAME
        assert outputs_left(outputs) == [OUTPUT_NAME]
        view = read_output(written)
        expected = expected_from_truth(emu)

    assert view.job_id == emu.batch_id
    assert expected.jobs == 90
    # The data set covers the cases the aggregations must handle.
    assert expected.job_statuses["ERROR"] >= 1  # a job without metrics (slot 6)
    assert len(expected.scalars["Localization error"]) < expected.jobs  # gaps
    assert_matches_truth(view, expected)
    assert "Missing jobs" not in by_name(view)


async def test_the_output_does_not_depend_on_the_order_jobs_arrive_in(tmp_path: Path) -> None:
    """One worker fetches jobs in listing order; many finish them in any order."""
    outputs: list[bytes] = []
    for concurrency in (1, 32):
        run_dir = tmp_path / f"c{concurrency}"
        toml = run_dir / "stook.toml"
        toml.parent.mkdir()
        toml.write_text(f"[fetch]\nconcurrency = {concurrency}\n\n{BATCH_TOML}")
        async with emulated_batch(run_dir / "inputs", jobs_per_batch=40, seed=5):
            written = await run(
                RunOptions(inputs=run_dir / "inputs", outputs=run_dir / "out", config=toml)
            )
        outputs.append(written.read_bytes())
    assert outputs[0] == outputs[1]
