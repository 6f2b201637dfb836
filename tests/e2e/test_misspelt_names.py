"""A misspelt aggregation metric or data name ends the run once the first jobs' listings
show it missing from every job seen (issue 36), not after the whole batch."""

from __future__ import annotations

from pathlib import Path

import pytest

from stook.service.modes import BatchInputs, ConfigError, detect, load, run_batch
from stook.testing import emulated_batch

_JOBS = 400


@pytest.mark.parametrize(
    ("table", "said"),
    [
        (
            '[[batch.weighted_mean]]\nname = "m"\nmetric = "Localisation error"\n'
            'weight = "Distance driven"\n',
            "scalar metric named 'Localisation error'; did you mean 'Localization error'?",
        ),
        (
            '[[batch.histogram]]\nname = "h"\ndata = "sppeds"\nlower = 0\nupper = 1\nbuckets = 4\n',
            "metrics data named 'sppeds'; did you mean 'speeds'?",
        ),
    ],
)
async def test_a_misspelt_name_ends_the_run_after_the_first_jobs(
    tmp_path: Path, table: str, said: str
) -> None:
    toml = tmp_path / "stook.toml"
    toml.write_text("[batch]\ndefaults = false\n\n" + table)
    async with emulated_batch(tmp_path / "inputs", jobs_per_batch=_JOBS, seed=3) as emu:
        batch = detect(tmp_path / "inputs")
        assert isinstance(batch, BatchInputs)
        with pytest.raises(ConfigError) as raised:
            await run_batch(batch, load(toml), tmp_path / "out")
        listed = emu.stats.endpoints["api:list_job_metrics"]
    assert said in str(raised.value)
    assert "none of the first" in str(raised.value)
    assert listed < 300  # long before the end of the batch
    assert not (tmp_path / "out" / "metrics.binproto").exists()
