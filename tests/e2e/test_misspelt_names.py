"""A misspelt aggregation metric or data name ends the run once the first jobs' listings
show it missing from every job seen (issue 36), not after the whole batch."""

from __future__ import annotations

from pathlib import Path

import pytest

from stook.service.cli._help import RUN_EPILOG
from stook.service.modes import BatchInputs, ConfigError, detect, load, run_batch
from stook.service.modes._batch import FIRST_JOBS
from stook.testing import emulated_batch

_JOBS = 1_000


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
    assert f"none of the first {FIRST_JOBS} jobs has" in str(raised.value)
    # Long before the end of the batch: after its first 100 jobs with metrics, and the
    # listings in flight then (the concurrency's 64), not its 1,000 jobs.
    assert listed < _JOBS // 3
    assert not (tmp_path / "out" / "metrics.binproto").exists()


def test_the_help_and_the_docs_say_when_a_misspelt_name_is_found() -> None:
    said = f"once the first {FIRST_JOBS} jobs' listings show it missing from all of them"
    assert said in " ".join(RUN_EPILOG.split())
    assert said in (Path(__file__).parents[2] / "docs" / "cli.md").read_text()
