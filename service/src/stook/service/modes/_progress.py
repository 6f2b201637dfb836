"""How a run shows its progress: a bar on a terminal, a log event every ~10 s off one.

On a terminal (`TerminalProgress`): a rich progress bar whose total is the job count the
API gives (the listing's ``total``, a report's batches' ``totalJobs``), not the jobs listed
so far, with percentage, rate and ETA; report mode adds a bar of batches. Requests/s and
retries are counters beside the bar. rich is imported with the first update, so that
start-up does not pay for it.

Off a terminal (`LogProgress`, the platform's log view): one ``fetch progress`` event every
``interval`` seconds (jobs done of total, requests/s, retries, elapsed), so that a long run
shows life between its first and last lines; at warning level, naming the origin and its
last failure, while requests are being retried.

``STOOK_PROGRESS`` picks one by hand (``bar``, ``log`` or ``none``; default ``auto``) and
``STOOK_PROGRESS_INTERVAL`` sets the seconds between progress events (default 10).
"""

from __future__ import annotations

import os
import sys
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol, TextIO

from stook.service.modes._errors import ConfigError

if TYPE_CHECKING:
    from rich.progress import Progress as RichProgress
    from rich.progress import TaskID

DEFAULT_INTERVAL_S = 10.0
PROGRESS_ENV = "STOOK_PROGRESS"
INTERVAL_ENV = "STOOK_PROGRESS_INTERVAL"


@dataclass(frozen=True, slots=True)
class Snapshot:
    """How far a fetch got: jobs (and a report's batches) and the client's traffic."""

    jobs_done: int
    jobs_listed: int
    jobs_total: int | None = None  # from the API; None while it is not known
    batches_done: int | None = None  # report mode only
    batches_total: int | None = None
    requests: int = 0
    retries: int = 0
    bytes_received: int = 0
    # Requests being retried now: the origins and their last failure ("" when none).
    retrying: str = ""

    @property
    def total(self) -> int | None:
        """The job count to show progress against; never below what was listed already."""
        if self.jobs_total is None:
            return None
        return max(self.jobs_total, self.jobs_listed, self.jobs_done)

    def of_total(self) -> str:
        """``1,204 of 5,000 jobs``, or of those listed while the total is unknown."""
        total = self.total
        shown = f"{total:,}" if total is not None else f"{self.jobs_listed:,} listed"
        return f"{self.jobs_done:,} of {shown} jobs"


class Progress(Protocol):
    def update(self, snapshot: Snapshot) -> None: ...

    def close(self) -> None: ...


class NoProgress:
    def update(self, snapshot: Snapshot) -> None:
        pass

    def close(self) -> None:
        pass


def human_bytes(count: int) -> str:
    """``27.2 MB`` for 27,224,097 bytes: decimal units, three significant digits."""
    value = float(count)
    for unit in ("B", "kB", "MB", "GB", "TB"):
        if abs(value) < 1000 or unit == "TB":
            return f"{count} B" if unit == "B" else f"{value:.3g} {unit}"
        value /= 1000
    raise AssertionError("unreachable")


class _Rate:
    """A count's rate over the last `window` seconds (its samples older than that dropped)."""

    def __init__(self, window: float = 10.0) -> None:
        self._window = window
        self._samples: deque[tuple[float, int]] = deque()

    def add(self, now: float, count: int) -> float:
        samples = self._samples
        samples.append((now, count))
        while len(samples) > 2 and now - samples[1][0] >= self._window:
            samples.popleft()
        (first_t, first_n), (last_t, last_n) = samples[0], samples[-1]
        return (last_n - first_n) / (last_t - first_t) if last_t > first_t else 0.0


class TerminalProgress:
    """A rich progress bar on `stream`, for a terminal; `force_terminal` draws it on any
    stream (tests). Redrawn a few times a second by rich's own thread, so that the ETA
    moves on even while no job completes."""

    def __init__(
        self,
        stream: TextIO | None = None,
        *,
        label: str = "jobs",
        force_terminal: bool | None = None,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self._stream = stream or sys.stderr
        self._label = label
        self._force = force_terminal
        self._clock = clock
        self._requests = _Rate()
        self._bar: RichProgress | None = None
        self._jobs: TaskID | None = None
        self._batches: TaskID | None = None

    def update(self, snapshot: Snapshot) -> None:
        bar = self._bar
        if bar is None:
            bar = self._bar = self._make(report=snapshot.batches_done is not None)
            self._show(bar, snapshot)
            bar.start()  # drawn first with this snapshot's total, not an unknown one
        else:
            self._show(bar, snapshot)

    def _show(self, bar: RichProgress, snapshot: Snapshot) -> None:
        if self._batches is not None:
            bar.update(
                self._batches, completed=snapshot.batches_done or 0, total=snapshot.batches_total
            )
        rate = self._requests.add(self._clock(), snapshot.requests)
        retries = "retry" if snapshot.retries == 1 else "retries"
        assert self._jobs is not None
        bar.update(
            self._jobs,
            completed=snapshot.jobs_done,
            total=snapshot.total,
            stats=f"{rate:,.0f} req/s  {snapshot.retries:,} {retries}"
            + (f"  retrying {snapshot.retrying}" if snapshot.retrying else ""),
        )

    def _make(self, *, report: bool) -> RichProgress:
        # rich costs tens of milliseconds to import: paid at the first job, not at start-up.
        from rich.console import Console
        from rich.progress import (
            BarColumn,
            MofNCompleteColumn,
            Progress,
            TaskProgressColumn,
            TextColumn,
            TimeRemainingColumn,
        )

        console = Console(file=self._stream, force_terminal=self._force)
        bar = Progress(
            TextColumn("{task.description:>7}"),
            BarColumn(bar_width=None),
            MofNCompleteColumn(),
            TaskProgressColumn(),
            _rate_column(),
            TextColumn("ETA"),
            TimeRemainingColumn(),
            TextColumn("{task.fields[stats]}"),
            console=console,
            refresh_per_second=4,
            speed_estimate_period=30.0,
            get_time=self._clock,
        )
        if report:  # a report's batches above its jobs: the coarse progress first
            self._batches = bar.add_task("batches", total=None, stats="")
        self._jobs = bar.add_task(self._label, total=None, stats="")
        return bar

    def close(self) -> None:
        if self._bar is not None:
            self._bar.stop()  # leaves the last drawing in place, above what follows
            self._bar = None


def _rate_column() -> Any:
    """A column of each bar's rate (jobs/s, batches/s), from rich's estimate over 30 s;
    its class is made on first use, since rich is imported only then."""
    from rich.progress import ProgressColumn, Task
    from rich.text import Text

    class RateColumn(ProgressColumn):
        def render(self, task: Task) -> Text:
            speed = task.finished_speed or task.speed
            unit = f"{task.description.strip()}/s"
            return Text(f"{speed:,.1f} {unit}" if speed is not None else f"? {unit}")

    return RateColumn()


class LogProgress:
    """One structlog ``fetch progress`` event every `interval` seconds, for log views."""

    def __init__(
        self,
        *,
        interval: float = DEFAULT_INTERVAL_S,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        import structlog

        self._log = structlog.get_logger("stook.progress")
        self._interval = interval
        self._clock = clock
        self._started = clock()
        self._last = self._started
        self._last_requests = 0

    def update(self, snapshot: Snapshot) -> None:
        now = self._clock()
        if now - self._last < self._interval:
            return
        span, self._last = now - self._last, now
        elapsed = now - self._started
        fields: dict[str, Any] = {}
        if snapshot.batches_done is not None:  # report mode
            fields["batches_done"] = snapshot.batches_done
            fields["batches_total"] = snapshot.batches_total
        total = snapshot.total
        if total:
            fields["percent"] = round(100 * snapshot.jobs_done / total, 1)
            if 0 < snapshot.jobs_done < total:
                remaining = elapsed * (total - snapshot.jobs_done) / snapshot.jobs_done
                fields["eta_s"] = round(remaining, 1)
        if snapshot.retrying:  # said louder: the run is waiting for an origin
            fields["retrying"] = snapshot.retrying
        emit = self._log.warning if snapshot.retrying else self._log.info
        emit(
            "fetch progress",
            progress=snapshot.of_total(),
            jobs_done=snapshot.jobs_done,
            jobs_total=total,
            **fields,
            requests_per_s=round((snapshot.requests - self._last_requests) / span, 1),
            retries=snapshot.retries,
            received=human_bytes(snapshot.bytes_received),
            elapsed_s=round(elapsed, 1),
        )
        self._last_requests = snapshot.requests

    def close(self) -> None:
        pass


def interval_from_env() -> float:
    """``STOOK_PROGRESS_INTERVAL`` in seconds, or the default 10; anything else is exit 2."""
    text = os.environ.get(INTERVAL_ENV, "").strip()
    if not text:
        return DEFAULT_INTERVAL_S
    try:
        value = float(text)
    except ValueError:
        value = -1.0
    if not 0 < value < float("inf"):
        raise ConfigError(f"{INTERVAL_ENV} must be a positive number of seconds, got {text!r}")
    return value


def for_stream(
    stream: TextIO | None = None, *, label: str = "jobs", interval: float | None = None
) -> Progress:
    """The progress display for `stream` (stderr): a bar on a terminal, events off one.

    ``STOOK_PROGRESS=bar|log|none`` overrides the choice; ``interval`` (default
    ``STOOK_PROGRESS_INTERVAL`` or 10 s) spaces the events.
    """
    out = stream or sys.stderr
    choice = os.environ.get(PROGRESS_ENV, "auto").strip().lower() or "auto"
    if choice not in ("auto", "bar", "log", "none"):
        raise ConfigError(f"{PROGRESS_ENV} must be auto, bar, log or none, got {choice!r}")
    seconds = interval_from_env() if interval is None else interval
    if choice == "none":
        return NoProgress()
    if choice == "auto":
        choice = "bar" if _is_tty(out) else "log"
    if choice == "bar":
        return TerminalProgress(out, label=label, force_terminal=True if not _is_tty(out) else None)
    return LogProgress(interval=seconds)


def _is_tty(stream: TextIO) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False


class Tally:
    """A Progress that remembers the last snapshot it was given, for the line that an
    interrupted run ends with; it passes every update on to the display it wraps."""

    def __init__(self, shown: Progress | None = None) -> None:
        self._shown = shown or NoProgress()
        self.last = Snapshot(jobs_done=0, jobs_listed=0)

    @property
    def done(self) -> int:
        return self.last.jobs_done

    @property
    def listed(self) -> int:
        return self.last.jobs_listed

    def update(self, snapshot: Snapshot) -> None:
        self.last = snapshot
        self._shown.update(snapshot)

    def close(self) -> None:
        self._shown.close()
