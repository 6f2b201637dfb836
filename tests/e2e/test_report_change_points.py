"""Report mode end to end: a step change mid-window is named (batch, build, levels) in
``Change points`` and drawn on its line, and the experiences seeded to vary wildly lead
``Unstable experiences`` — through `stook run`, against the emulator's ground truth."""

from __future__ import annotations

import statistics
from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.emulator import Emulator
from tests.e2e.support import EmulatorThread, bar_chart, by_name, config, outputs_left, text_of
from tests.e2e.test_report_metrics import (
    assert_report_matches,
    expected_report,
    lines,
    run_report_cli,
    status_name,
)
from tests.failures import failure_lines

DIST = "Mean distance driven"
LOC = "Mean localization error"
STEP = 6
UNSTABLE = (3, 7)
SETTINGS = {
    "seed": 5,
    "report_batches": 12,
    "report_jobs_per_batch": 40,
    "experiences": 10,  # four jobs of each experience per batch
    "report_regression": False,
}


@pytest.fixture(scope="module")
def stepped() -> Iterator[Emulator]:
    emulator_config = config(
        **SETTINGS, report_step_change_batch=STEP, report_unstable_experiences=UNSTABLE
    )
    with EmulatorThread(emulator_config) as emulator:
        yield emulator


@pytest.mark.slow
def test_the_step_change_batch_is_named_with_its_build_and_levels(
    stepped: Emulator, tmp_path: Path
) -> None:
    view = run_report_cli(stepped, tmp_path).view()
    expected = expected_report(stepped)
    assert_report_matches(view, expected)
    metrics = by_name(view)
    batch = expected.batches[STEP]
    build = str(batch.build_id)[:8]
    where = f"at {batch.friendly_name} (build {build}, {batch.created:%Y-%m-%d %H:%M} UTC)"

    distances = [p.y for p in expected.scalar_lines[DIST]]
    before = statistics.fmean(distances[:STEP])
    after = statistics.fmean(distances[STEP:])
    changes = metrics["Change points"]
    text = text_of(changes)
    assert f"- {DIST!r} moved {where}: {before:.6g} m → {after:.6g} m " in text, text
    assert f"({(after - before) / before:+.1%})" in text
    assert f"{LOC!r} moved" not in text  # stable, and no seeded regression here
    failing = stepped.dataset.experiences[0].name
    assert f"- {failing!r} failure rate moved {where}: " in text
    assert "→ 100% (" in text
    assert status_name(changes) == "FAIL_WARN"  # a failure rate rose

    # Drawn on the line: the level series, marked at the step's batch.
    data, level = lines(view, metrics[f"{DIST} over time"])
    assert data.y == distances
    assert level.y[:STEP] == pytest.approx([before] * STEP)
    assert level.y[STEP:] == pytest.approx([after] * (len(distances) - STEP))
    assert [i for i, s in enumerate(level.statuses) if s == "FAIL_WARN"] == [STEP]
    assert len(lines(view, metrics[f"{LOC} over time"])) == 1
    # ... and the experience's failure rate.
    (rate,) = lines(view, metrics["Failure rate over time"])
    assert rate.y[STEP:] == [100.0] * (len(distances) - STEP)
    assert rate.statuses[STEP] == "FAIL_WARN"


@pytest.mark.slow
def test_the_seeded_unstable_experiences_lead_the_ranking(
    stepped: Emulator, tmp_path: Path
) -> None:
    view = run_report_cli(stepped, tmp_path).view()
    metrics = by_name(view)
    names = {stepped.dataset.experiences[i].name for i in UNSTABLE}
    ranked = list(bar_chart(view, metrics["Unstable experiences"]))
    assert set(ranked[:2]) == names
    rows = text_of(metrics["Unstable experiences (details)"]).splitlines()[2:4]
    assert {r.split(" | ")[0].lstrip("| ") for r in rows} == names
    assert all(r.split(" | ")[1] == "Localization error" for r in rows)


@pytest.mark.slow
def test_without_the_step_nothing_is_named_there(stepped: Emulator, tmp_path: Path) -> None:
    with EmulatorThread(config(**SETTINGS)) as emu:
        view = run_report_cli(emu, tmp_path / "calm").view()
        expected = expected_report(emu)
    assert_report_matches(view, expected)
    metrics = by_name(view)
    text = text_of(metrics["Change points"])
    assert f"{DIST!r} moved" not in text
    assert f"{LOC!r} moved" not in text
    assert len(lines(view, metrics[f"{DIST} over time"])) == 1
    # The seeded experiences' spread stands far above anything the calm report shows.
    calm = bar_chart(view, metrics["Unstable experiences"])
    seeded_view = run_report_cli(stepped, tmp_path / "stepped").view()
    seeded = bar_chart(seeded_view, by_name(seeded_view)["Unstable experiences"])
    assert min(list(seeded.values())[:2]) > 1.2 * max(calm.values())


# Turning them off is also checked where it is decided, quickly: the [report] settings
# (tests/service/modes/test_report_change_settings.py) and the default aggregations.
@pytest.mark.slow
def test_turned_off_the_report_has_neither(stepped: Emulator, tmp_path: Path) -> None:
    toml = "[report]\nchange_points = false\nunstable_experiences = false\n"
    view = run_report_cli(stepped, tmp_path, toml).view()
    metrics = by_name(view)
    assert not {"Change points", "Unstable experiences", "Failure rate over time"} & set(metrics)
    assert len(lines(view, metrics[f"{DIST} over time"])) == 1


@pytest.mark.slow
def test_the_demo_shows_a_change_point(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from stook.emulator import Dataset, EmulatorConfig
    from stook.testing._demo import REPORT_BATCHES, run_demo

    assert run_demo(jobs=12, output=tmp_path, seed=7) == 0
    out = capsys.readouterr().out
    world = Dataset(EmulatorConfig(seed=7, report_batches=REPORT_BATCHES))
    step = world.report_batches()[REPORT_BATCHES // 2]
    assert "  Change points: " in out
    assert f"- {DIST!r} moved at {step.friendly_name} (build {str(step.build_id)[:8]}, " in out


@pytest.mark.parametrize(
    ("toml", "said"),
    [
        ("[report]\nchange_penalty = -2\n", "[report] change_penalty must be a positive number"),
        ("[report]\nchange_points = 1\n", "[report] change_points must be true or false"),
        ("[[report.unstable_experiences]]\ntop_n = 0\n", "top_n must be at least 1"),
    ],
)
def test_a_bad_setting_exits_2_before_any_request(toml: str, said: str, tmp_path: Path) -> None:
    with EmulatorThread(config(**SETTINGS)) as emu:
        run = run_report_cli(emu, tmp_path, toml)
        requests = sum(emu.stats.requests.values())
    assert run.code == 2, run.err
    (line,) = failure_lines(run.err)
    assert said in line
    assert requests == 0
    assert outputs_left(run.outputs) == []
