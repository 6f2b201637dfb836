"""Batch summaries end to end: batch mode writes one, report mode reads one per batch and
gives the same bytes as from the per-job listings, with summaries, without, and mixed."""

from __future__ import annotations

from pathlib import Path

import pytest

from stook.emulator import Emulator, EmulatorConfig
from stook.sdk import read_job_metrics
from stook.sdk.aggregations import SUMMARY_DATA_NAME, summary_from_data
from stook.service.cli import run_cli
from tests.e2e.support import EmulatorThread, config, write_batch_inputs
from tests.e2e.test_report_metrics import run_report_cli

BATCHES = 6
JOBS = 12
# Every default report metric, the job-metric ones included.
REPORT_TOML = '[report]\njob_metrics = ["Localization error", "Max speed", "Collisions"]\n'


def _emulator(**overrides: object) -> EmulatorConfig:
    return config(
        seed=23,
        report_batches=BATCHES,
        report_jobs_per_batch=JOBS,
        report_unstable_experiences=(1,),
        experiences=5,
        cache_jobs=BATCHES * JOBS + 64,
        **overrides,
    )


def _report(emu: Emulator, tmp: Path, toml: str = REPORT_TOML) -> tuple[bytes, int, int]:
    """The report's bytes, and the job listings and job-metric listings it asked for."""
    before = emu.stats.endpoints.copy()
    run = run_report_cli(emu, tmp, toml)
    assert run.code == 0, run.err
    after = emu.stats.endpoints
    jobs = after["api:list_jobs"] - before["api:list_jobs"]
    job_metrics = after["api:list_job_metrics"] - before["api:list_job_metrics"]
    return run.output.read_bytes(), jobs, job_metrics


def test_reports_are_identical_with_summaries_without_and_mixed(tmp_path: Path) -> None:
    outputs: dict[str, bytes] = {}
    with EmulatorThread(_emulator()) as emu:
        outputs["none"], jobs, job_metrics = _report(emu, tmp_path / "none")
        assert jobs >= BATCHES
        assert job_metrics >= BATCHES * JOBS  # a page or more per job
        every_job = job_metrics
    with EmulatorThread(_emulator(batch_summaries="exact")) as emu:
        outputs["all"], jobs, job_metrics = _report(emu, tmp_path / "all")
        assert (jobs, job_metrics) == (0, 0)  # O(batches): no job is listed at all
        outputs["listings"], jobs, _ = _report(
            emu, tmp_path / "off", REPORT_TOML + "use_summaries = false\n"
        )
        assert jobs >= BATCHES
    mixed = _emulator(batch_summaries="exact", report_batches_without_summary=(0, 3, 4))
    with EmulatorThread(mixed) as emu:
        outputs["mixed"], jobs, job_metrics = _report(emu, tmp_path / "mixed")
        assert 3 * JOBS <= job_metrics < every_job  # only the batches without one
    assert outputs["all"] == outputs["none"]
    assert outputs["listings"] == outputs["none"]
    assert outputs["mixed"] == outputs["none"]


def test_default_report_reads_one_summary_per_batch(tmp_path: Path) -> None:
    with EmulatorThread(_emulator(batch_summaries="exact")) as emu:
        plain, jobs, _ = _report(emu, tmp_path / "a", "")
        assert jobs == 0
        data = emu.stats.endpoints["api:list_batch_metrics_data"]
        assert data == BATCHES
    with EmulatorThread(_emulator()) as emu:
        assert _report(emu, tmp_path / "b", "")[0] == plain


def test_batch_mode_writes_a_summary_a_report_can_read(tmp_path: Path) -> None:
    with EmulatorThread(_emulator(jobs_per_batch=20)) as emu:
        write_batch_inputs(tmp_path / "inputs", emu)
        argv = ["run", "--inputs", str(tmp_path / "inputs"), "--outputs", str(tmp_path / "out")]
        assert run_cli([*argv, "--log-level", "warning"]) == 0
        truth = {j.id: j for j in emu.dataset.jobs(emu.batch_id)}
    view = read_job_metrics((tmp_path / "out" / "metrics.binproto").read_bytes())
    found = [d for d in view.data if d.name == SUMMARY_DATA_NAME]
    assert len(found) == 1
    summary = summary_from_data(found[0])
    assert {j.job_id for j in summary.jobs} == set(truth)
    for job in summary.jobs:
        assert job.conflated_status == truth[job.job_id].conflated_status
        assert job.experience_name == truth[job.job_id].experience.name


def _batch_data_names(emu: Emulator, tmp: Path, *extra: str, toml: str = "") -> list[str]:
    """Batch mode on the emulator's main batch; the names of the metrics data it wrote."""
    write_batch_inputs(tmp / "inputs", emu)
    (tmp / "stook.toml").write_text(toml)
    argv = ["run", "--inputs", str(tmp / "inputs"), "--outputs", str(tmp / "out")]
    argv += ["--config", str(tmp / "stook.toml"), "--log-level", "error", *extra]
    assert run_cli(argv) == 0
    view = read_job_metrics((tmp / "out" / "metrics.binproto").read_bytes())
    return [d.name for d in view.data]


def test_output_summary_false_writes_none(tmp_path: Path) -> None:
    with EmulatorThread(_emulator(jobs_per_batch=10)) as emu:
        assert SUMMARY_DATA_NAME in _batch_data_names(emu, tmp_path / "on")
        off = _batch_data_names(emu, tmp_path / "off", toml="[output]\nsummary = false\n")
    assert SUMMARY_DATA_NAME not in off


def test_no_summary_when_some_jobs_are_missing(tmp_path: Path) -> None:
    # A summary without the broken job would give reports wrong numbers: none is written.
    with EmulatorThread(_emulator(jobs_per_batch=20, broken_jobs=(3,))) as emu:
        names = _batch_data_names(
            emu, tmp_path, "--allow-missing-jobs", "0.1", toml="[fetch]\nretry_for = 1\n"
        )
    assert names  # the batch's own data is there
    assert SUMMARY_DATA_NAME not in names


@pytest.mark.parametrize(
    ("patch", "said"),
    [
        ("SUMMARY_VERSION", "batch summary written by a newer stook"),
        ("text", "batch summary unreadable"),
    ],
)
def test_a_summary_it_cannot_read_falls_back_to_the_listings(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, patch: str, said: str
) -> None:
    from stook.sdk.aggregations import _summary

    with EmulatorThread(_emulator()) as emu:
        plain, _, _ = _report(emu, tmp_path / "plain")
    with EmulatorThread(_emulator(batch_summaries="exact")) as emu:
        with monkeypatch.context() as mp:
            if patch == "SUMMARY_VERSION":
                mp.setattr(_summary, "SUMMARY_VERSION", _summary.SUMMARY_VERSION + 1)
            else:
                mp.setattr(_summary.BatchSummaryWriter, "text", lambda self: "AAAA")
            for batch in emu.dataset.report_batches():
                emu.dataset.batch_output(batch.id)  # written now, while patched
        before = emu.stats.endpoints["api:list_jobs"]
        run = run_report_cli(emu, tmp_path / "newer", REPORT_TOML)
        assert emu.stats.endpoints["api:list_jobs"] - before >= BATCHES
    assert run.code == 0, run.err
    assert run.output.read_bytes() == plain
    assert run.err.count(said) == BATCHES
