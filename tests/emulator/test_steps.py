"""The report knobs of a step change mid-window and of unstable experiences: what they
change in the emulated data, what they leave alone, and the values they refuse."""

from __future__ import annotations

import statistics

import pytest

from stook.emulator import Dataset, EmulatorConfig
from stook.emulator._steps import STEP_EXPERIENCE, STEP_FACTOR, UNSTABLE_SPAN

DIST = "Mean distance driven"
BASE = EmulatorConfig(report_batches=10, report_jobs_per_batch=20, experiences=5, seed=3)


def _distances(ds: Dataset) -> list[float]:
    return [s[DIST][0] for _, s in ds.report_batch_scalars()]


def test_the_step_moves_a_batch_metric_and_an_experience_from_its_batch_on() -> None:
    calm, stepped = Dataset(BASE), Dataset(BASE.replace(report_step_change_batch=4))
    before, after = _distances(calm), _distances(stepped)
    assert after[:4] == before[:4]
    assert after[4:] == pytest.approx([v * STEP_FACTOR for v in before[4:]])
    experience = stepped.experiences[STEP_EXPERIENCE].name
    for k, (batch, per_experience) in enumerate(stepped.report_job_statuses()):
        statuses = per_experience[experience]
        if k >= 4:
            assert set(statuses) <= {"BLOCKER", "ERROR", "CANCELLED"}, batch.friendly_name
            assert "BLOCKER" in statuses
    # Everything else is as it was: other experiences' jobs, the main batch.
    for (_, calm_jobs), (_, stepped_jobs) in zip(
        calm.report_job_statuses(), stepped.report_job_statuses(), strict=True
    ):
        for name, statuses in calm_jobs.items():
            if name != experience:
                assert stepped_jobs[name] == statuses
    assert [j.conflated_status for j in calm.jobs(calm.main_batch_id)] == [
        j.conflated_status for j in stepped.jobs(stepped.main_batch_id)
    ]


def test_unstable_experiences_scale_their_localization_error_per_batch() -> None:
    calm, wild = Dataset(BASE), Dataset(BASE.replace(report_unstable_experiences=(2,)))
    factors = []
    for batch in calm.report_batches():
        for job, twin in zip(calm.jobs(batch.id), wild.jobs(batch.id), strict=True):
            a = calm.truth(batch.id, job.id).scalars.get("Localization error")
            b = wild.truth(batch.id, twin.id).scalars.get("Localization error")
            if job.experience.index != 2:
                assert a == b
            elif a is not None and b is not None:
                factors.append((batch.id, b / a))
                assert 1 / UNSTABLE_SPAN <= b / a <= UNSTABLE_SPAN
    per_batch = {bid: f for bid, f in factors}
    assert all(f == pytest.approx(per_batch[bid]) for bid, f in factors)  # one per batch
    assert statistics.pstdev(per_batch.values()) > 0.5
    # The main batch (batch mode's) is left alone.
    main = wild.main_batch_id
    assert all(j.localization_factor == 1.0 for j in wild.jobs(main))


@pytest.mark.parametrize(
    ("change", "message"),
    [
        ({"report_step_change_batch": -1}, "report_step_change_batch"),
        ({"report_step_change_batch": True}, "report_step_change_batch"),
        ({"report_unstable_experiences": (-2,)}, "report_unstable_experiences"),
    ],
)
def test_bad_values_are_refused(change: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        BASE.replace(**change)


def test_the_knobs_cross_process_boundaries_as_json() -> None:
    chosen = BASE.replace(report_step_change_batch=3, report_unstable_experiences=(1, 4))
    again = EmulatorConfig.from_dict({**chosen.to_dict(), "report_unstable_experiences": [1, 4]})
    assert again == chosen
