"""Report mode end to end: the emulator's seeded regression is found, stable series are
not flagged, and too few batches give no verdict."""

from __future__ import annotations

import statistics
from pathlib import Path

import pytest

from stook.sdk import MetricStatus
from tests.e2e.support import EmulatorThread, by_name, config, text_of
from tests.e2e.test_report_metrics import (
    assert_report_matches,
    expected_report,
    run_report_cli,
    status_name,
    the_line,
)

LOC = "Mean localization error"
DIST = "Mean distance driven"
STATUS_RANK = {"PASSED": 0, "NOT_APPLICABLE": 0, "FAIL_WARN": 1, "FAIL_BLOCK": 2}


def test_the_seeded_regression_is_detected(tmp_path: Path) -> None:
    with EmulatorThread(config(seed=5, report_batches=12, report_jobs_per_batch=20)) as emu:
        view = run_report_cli(emu, tmp_path).view()
        expected = expected_report(emu)
    assert_report_matches(view, expected)
    metrics = by_name(view)

    # The truth: the latest batch's localization error doubled; the distance did not move.
    loc = [p.y for p in expected.scalar_lines[LOC]]
    baseline = loc[:-1][-10:]
    median = statistics.median(baseline)
    assert loc[-1] > 1.9 * median
    latest, previous = expected.batches[-1], expected.batches[-2]
    first_in_window = expected.batches[-11]

    line = metrics[f"{LOC} over time"]
    assert status_name(line) == "FAIL_WARN"
    assert the_line(view, line).statuses[-1] == "FAIL_WARN"  # the batch metric's own status
    assert status_name(metrics[f"{DIST} over time"]) == "PASSED"

    regressions = metrics["Regressions"]
    assert status_name(regressions) == "FAIL_WARN"
    text = text_of(regressions)
    assert f"in the latest batch ({latest.friendly_name}, {latest.created:%Y-%m-%d %H:%M} UTC)" in (
        text
    )
    assert (
        f"- {LOC!r} moved: {loc[-1]:.6g} m in {latest.friendly_name} against a median of "
        f"{median:.6g} m" in text
    ), text
    assert f"over 10 batches from {first_in_window.friendly_name} to {previous.friendly_name}" in (
        text
    )
    assert f"({(loc[-1] - median) / median:+.1%})" in text
    assert f"since batch {previous.friendly_name}" in text
    assert f"{DIST!r} moved" not in text
    assert isinstance(view.status, MetricStatus)
    assert STATUS_RANK[view.status.name] >= STATUS_RANK["FAIL_WARN"]


def test_without_the_regression_the_stable_series_are_not_flagged(tmp_path: Path) -> None:
    emulator_config = config(
        seed=5, report_batches=12, report_jobs_per_batch=20, report_regression=False
    )
    with EmulatorThread(emulator_config) as emu:
        view = run_report_cli(emu, tmp_path).view()
        expected = expected_report(emu)
    assert_report_matches(view, expected)
    metrics = by_name(view)
    for name in (LOC, DIST):
        assert expected.verdicts[name] is False, name
        assert status_name(metrics[f"{name} over time"]) == "PASSED", name
        assert f"{name!r} moved" not in text_of(metrics["Regressions"])
    assert set(the_line(view, metrics[f"{LOC} over time"]).statuses) == {"PASSED"}
    # Whatever else moved (pass rates drift in this data set) is judged like the truth says.
    flagged = {n for n, v in expected.verdicts.items() if v}
    assert LOC not in flagged
    if not flagged:
        assert text_of(metrics["Regressions"]).startswith("No regression:")


def test_a_single_batch_gets_no_verdict(tmp_path: Path) -> None:
    with EmulatorThread(config(seed=5, report_batches=1, report_jobs_per_batch=20)) as emu:
        view = run_report_cli(emu, tmp_path).view()
        expected = expected_report(emu)
    assert len(expected.batches) == 1
    assert_report_matches(view, expected)
    metrics = by_name(view)
    regressions = metrics["Regressions"]
    assert status_name(regressions) == "NOT_APPLICABLE"
    assert "no regression verdict" in text_of(regressions)
    assert expected.batches[0].friendly_name in text_of(regressions)
    # Even the doubled value has nothing to be compared with.
    line = the_line(view, metrics[f"{LOC} over time"])
    assert line.x == [0.0]
    assert status_name(metrics[f"{LOC} over time"]) == "PASSED"


@pytest.mark.parametrize("batches", [3, 4])
def test_three_earlier_batches_are_needed(tmp_path: Path, batches: int) -> None:
    with EmulatorThread(config(seed=5, report_batches=batches, report_jobs_per_batch=12)) as emu:
        view = run_report_cli(emu, tmp_path).view()
        expected = expected_report(emu)
    assert_report_matches(view, expected)
    metrics = by_name(view)
    text = text_of(metrics["Regressions"])
    if batches == 3:  # two earlier batches: no verdict for any series
        assert set(expected.verdicts.values()) == {None}
        assert status_name(metrics["Regressions"]) == "NOT_APPLICABLE"
        assert text.startswith("No regression verdict"), text
        assert status_name(metrics[f"{LOC} over time"]) == "PASSED"
    else:  # three earlier batches: judged, and the doubled value is caught
        assert expected.verdicts[LOC] is True
        assert status_name(metrics[f"{LOC} over time"]) == "FAIL_WARN"
        assert f"{LOC!r} moved" in text
