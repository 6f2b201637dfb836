"""The progress displays: the bar's fixed total and ETA, the events' interval and fields."""

from __future__ import annotations

import dataclasses
import io
import re

import pytest
from structlog.testing import capture_logs

from stook.service.modes import ConfigError, RecordingProgress, for_stream, human_bytes
from stook.service.modes._progress import (
    SPARE_COLUMNS,
    FetchProgress,
    LogProgress,
    NoProgress,
    TerminalProgress,
)


class FakeClock:
    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def _plain(text: str) -> str:
    return re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", text)


@pytest.mark.parametrize(
    ("count", "text"),
    [(0, "0 B"), (999, "999 B"), (1_000, "1 kB"), (27_224_097, "27.2 MB"), (3 * 10**9, "3 GB")],
)
def test_human_bytes(count: int, text: str) -> None:
    assert human_bytes(count) == text


def test_the_total_is_the_apis_never_below_what_was_listed() -> None:
    assert FetchProgress(jobs_done=3, jobs_listed=10, jobs_total=500).total == 500
    assert FetchProgress(jobs_done=3, jobs_listed=10, jobs_total=None).total is None
    assert FetchProgress(jobs_done=3, jobs_listed=12, jobs_total=10).total == 12
    assert FetchProgress(jobs_done=1204, jobs_listed=1300, jobs_total=5000).of_total() == (
        "1,204 of 5,000 jobs"
    )
    assert FetchProgress(jobs_done=4, jobs_listed=9).of_total() == "4 of 9 listed jobs"


def test_the_bar_shows_the_fixed_total_percentage_rate_eta_and_retries(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setenv("COLUMNS", "120")
    stream, clock = io.StringIO(), FakeClock()
    bar = TerminalProgress(stream, force_terminal=True, clock=clock)
    for done in (0, 50, 100):
        clock.now += 5.0
        bar.update(
            FetchProgress(
                jobs_done=done,
                jobs_listed=done + 25,
                jobs_total=400,
                requests=done * 3,
                retries=7,
            )
        )
    bar.close()
    text = _plain(stream.getvalue())
    assert "100/400" in text  # the API's total, not the 125 listed
    assert not re.search(r"\d+/(25|75|125)\b", text)
    assert "25%" in text
    assert "10.0 jobs/s" in text  # 100 jobs in 10 s
    assert "ETA 0:00:30" in text  # 300 jobs to go at 10 a second
    assert "30 req/s  7 retries" in text
    assert "\n" not in text.strip()  # one line, redrawn: nothing wraps


def test_a_reports_bar_shows_batches_and_jobs(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("COLUMNS", "120")
    stream = io.StringIO()
    bar = TerminalProgress(stream, force_terminal=True)
    bar.update(FetchProgress(jobs_done=0, jobs_listed=0, batches_done=0, batches_total=None))
    bar.update(
        FetchProgress(
            jobs_done=80, jobs_listed=120, jobs_total=560, batches_done=2, batches_total=14
        )
    )
    bar.close()
    last = _plain(stream.getvalue())
    assert re.search(r"batches .* 2/14 ", last)
    assert re.search(r"jobs .* 80/560 ", last)


def test_the_bar_is_drawn_lazily() -> None:
    stream = io.StringIO()
    bar = TerminalProgress(stream, force_terminal=True)
    bar.close()  # nothing was shown: nothing drawn, rich not needed
    assert stream.getvalue() == ""


def test_one_event_per_interval_with_the_counts() -> None:
    clock = FakeClock()
    with capture_logs() as captured:
        shown = LogProgress(interval=10.0, clock=clock)
        for second in range(1, 26):
            clock.now = 100.0 + second
            shown.update(
                FetchProgress(
                    jobs_done=second * 8,
                    jobs_listed=200,
                    jobs_total=400,
                    requests=second * 20,
                    retries=second // 5,
                    bytes_received=second * 1_000_000,
                )
            )
        shown.close()
    events = [e for e in captured if e["event"] == "fetch progress"]
    assert [e["elapsed_s"] for e in events] == [10.0, 20.0]
    first = events[0]
    assert first["progress"] == "80 of 400 jobs"
    assert (first["jobs_done"], first["jobs_total"], first["percent"]) == (80, 400, 20.0)
    assert first["requests_per_s"] == 20.0
    assert first["retries"] == 2
    assert first["received"] == "10 MB"
    assert first["eta_s"] == 40.0
    assert first["log_level"] == "info"
    assert "batches_done" not in first


def test_a_reports_events_count_batches() -> None:
    clock = FakeClock()
    with capture_logs() as captured:
        shown = LogProgress(interval=1.0, clock=clock)
        clock.now += 1.5
        shown.update(
            FetchProgress(
                jobs_done=40, jobs_listed=80, jobs_total=None, batches_done=1, batches_total=3
            )
        )
    (event,) = captured
    assert (event["batches_done"], event["batches_total"]) == (1, 3)
    assert event["jobs_total"] is None
    assert event["progress"] == "40 of 80 listed jobs"


def test_an_event_while_requests_are_retried_is_a_warning_naming_the_origin() -> None:
    clock = FakeClock()
    retrying = "the API at http://127.0.0.1:9: HTTP 503"
    with capture_logs() as captured:
        shown = LogProgress(interval=1.0, clock=clock)
        clock.now += 1.5
        shown.update(FetchProgress(jobs_done=0, jobs_listed=0, retries=7, retrying=retrying))
        clock.now += 1.5
        shown.update(FetchProgress(jobs_done=3, jobs_listed=3, retries=7))  # the origin is back
    assert [(e["log_level"], e.get("retrying")) for e in captured] == [
        ("warning", retrying),
        ("info", None),
    ]


def test_the_choice_of_display(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.delenv("STOOK_PROGRESS", raising=False)
    monkeypatch.delenv("STOOK_PROGRESS_INTERVAL", raising=False)
    assert isinstance(for_stream(io.StringIO()), LogProgress)  # not a terminal
    monkeypatch.setenv("STOOK_PROGRESS", "bar")
    assert isinstance(for_stream(io.StringIO()), TerminalProgress)
    monkeypatch.setenv("STOOK_PROGRESS", "none")
    assert isinstance(for_stream(io.StringIO()), NoProgress)
    monkeypatch.setenv("STOOK_PROGRESS", "sparkles")
    with pytest.raises(ConfigError, match="STOOK_PROGRESS must be auto, bar, log or none"):
        for_stream(io.StringIO())
    monkeypatch.setenv("STOOK_PROGRESS", "log")
    monkeypatch.setenv("STOOK_PROGRESS_INTERVAL", "0")
    with pytest.raises(ConfigError, match="STOOK_PROGRESS_INTERVAL must be a positive number"):
        for_stream(io.StringIO())


def test_a_recording_progress_keeps_the_last_one() -> None:
    recording = RecordingProgress()
    recording.update(FetchProgress(jobs_done=5, jobs_listed=9, jobs_total=20))
    assert (recording.done, recording.listed, recording.last.total) == (5, 9, 20)
    recording.close()


def _drawn_lines(
    width: int, *snapshots: FetchProgress, monkeypatch: pytest.MonkeyPatch
) -> list[str]:
    """Each line of each drawing of the bar on a terminal `width` columns wide."""
    monkeypatch.setenv("COLUMNS", str(width))
    stream, clock = io.StringIO(), FakeClock()
    bar = TerminalProgress(stream, force_terminal=True, clock=clock)
    for snapshot in snapshots:
        clock.now += 5.0
        bar.update(snapshot)
    bar.close()
    text = _plain(stream.getvalue()).replace("\r", "\n")
    lines = [line for line in text.split("\n") if line.strip()]
    # The last drawing is drawn again as the bar closes, in the same place.
    return lines[: -2 if snapshots[-1].batches_done is not None else -1]


# A long run at its busiest: five-digit counts, retries, an origin being retried.
_BUSY = (
    FetchProgress(jobs_done=0, jobs_listed=100, jobs_total=12_000, requests=0, retries=0),
    FetchProgress(
        jobs_done=5_204, jobs_listed=6_000, jobs_total=12_000, requests=15_000, retries=1
    ),
    FetchProgress(
        jobs_done=10_950,
        jobs_listed=12_000,
        jobs_total=12_000,
        requests=31_000,
        retries=1_234,
        retrying="the API at https://api.resim.ai/v1: HTTP 503: Service Unavailable",
    ),
)


@pytest.mark.parametrize("width", [80, 60, 40, 24])
def test_no_line_of_the_bar_wraps_or_fills_the_last_columns(
    monkeypatch: pytest.MonkeyPatch, width: int
) -> None:
    report = [
        dataclasses.replace(s, batches_done=i * 6, batches_total=14) for i, s in enumerate(_BUSY)
    ]
    for snapshots in (_BUSY, report):
        lines = _drawn_lines(width, *snapshots, monkeypatch=monkeypatch)
        assert len(lines) == len(snapshots) * (2 if snapshots is report else 1)
        for line in lines:
            # Two columns free at the end: where a terminal echoes Ctrl-C as "^C".
            assert len(line) <= width - SPARE_COLUMNS, line
            assert re.match(r"\s*(jobs|batches) ", line), line  # a whole line, not a fragment
            assert re.search(r"\d/[\d,]+", line), line  # the count always stays


def test_at_80_columns_the_rate_eta_and_retries_stay(monkeypatch: pytest.MonkeyPatch) -> None:
    first, second, third = _drawn_lines(80, *_BUSY, monkeypatch=monkeypatch)
    assert re.fullmatch(r"jobs ━+ +0/12,000 +0%  \? jobs/s  ETA -:--:--  0 req/s  0 retries", first)
    # The request rate goes first; the bar, the rate and the ETA stay.
    assert re.fullmatch(
        r"jobs [━╸╺]+  5,204/12,000  43%  1,040\.8 jobs/s  ETA 0:00:07  1 retry", second
    ), second
    # While an origin is retried, that is said before the bar's rate, cut to fit.
    assert re.fullmatch(
        r"jobs [━╸╺]+ 10,950/12,000  91%  ETA 0:00:01  retrying the API at h\S*…", third
    ), third


def test_at_40_columns_the_count_percentage_and_eta(monkeypatch: pytest.MonkeyPatch) -> None:
    lines = _drawn_lines(40, *_BUSY, monkeypatch=monkeypatch)
    assert lines[1] == "jobs  5,204/12,000  43%  ETA 0:00:07"
    assert lines[2] == "jobs 10,950/12,000  91%  ETA 0:00:01"  # no room for the origin
    report = [
        dataclasses.replace(s, batches_done=i * 6, batches_total=14) for i, s in enumerate(_BUSY)
    ]
    *_, batches, jobs = _drawn_lines(40, *report, monkeypatch=monkeypatch)
    assert batches == "batches 12/14  86%  ETA 0:00:02"
    assert jobs.startswith("   jobs 10,950/12,000  91%")  # aligned under "batches"


def test_however_narrow_the_label_and_the_count_stay(monkeypatch: pytest.MonkeyPatch) -> None:
    *_, last = _drawn_lines(20, *_BUSY, monkeypatch=monkeypatch)
    assert last == "jobs 10,950/12,000"
    # Wide: everything, the bar filling what the rest leaves, the origin in full.
    *_, last = _drawn_lines(200, *_BUSY, monkeypatch=monkeypatch)
    assert len(last) == 200 - SPARE_COLUMNS
    assert last.endswith("1,234 retries  retrying " + _BUSY[-1].retrying)
