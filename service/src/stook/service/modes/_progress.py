"""How a run shows its progress: a bar on a terminal, a log event every ~10 s off one.

On a terminal (`TerminalProgress`): a bar whose total is the job count the API gives (the
listing's ``total``, a report's batches' ``totalJobs``), not the jobs listed so far, with
percentage, rate and ETA; report mode adds a bar of batches. Requests/s, retries and the
origin being retried follow the bar. Each line fits the terminal's width less two columns
(`fit_line`: parts go as it narrows, the count of jobs done never), so that it never
wraps, nor does the "^C" a terminal echoes after it. rich draws it (rich.live), imported
with the first update, so that start-up does not pay for it.

Off a terminal (`LogProgress`, the platform's log view): one ``fetch progress`` event every
``interval`` seconds (jobs done of total, requests/s, retries, elapsed), so that a long run
shows life between its first and last lines; at warning level, naming the origin and its
last failure, while requests are being retried.

``STOOK_PROGRESS`` picks one by hand (``bar``, ``log`` or ``none``; default ``auto``) and
``STOOK_PROGRESS_INTERVAL`` sets the seconds between progress events (default 10).

The words, one for each thing: a fetch's progress at one moment is a `FetchProgress` (a
shard's, sent to the driver, a `ShardProgress`; the running shards' together,
`ShardsProgress`, modes/_engine.py); a display of it is a `Progress` (`TerminalProgress`,
`LogProgress`, `NoProgress`, and `RecordingProgress`, which keeps the last one for the line
an interrupted run ends with); a client's requests, retries and bytes are its `Traffic`
(modes/_pipeline.py), summed from the API layer's `TrafficCounts`.
"""

from __future__ import annotations

import math
import os
import sys
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass
from datetime import timedelta
from typing import TYPE_CHECKING, Any, Protocol, TextIO

from stook.service.modes._errors import ConfigError

if TYPE_CHECKING:
    from rich.console import Console, ConsoleOptions, RenderResult
    from rich.live import Live

DEFAULT_INTERVAL_S = 10.0
PROGRESS_ENV = "STOOK_PROGRESS"
INTERVAL_ENV = "STOOK_PROGRESS_INTERVAL"


@dataclass(frozen=True, slots=True)
class FetchProgress:
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
    def update(self, snapshot: FetchProgress) -> None: ...

    def close(self) -> None: ...


class NoProgress:
    def update(self, snapshot: FetchProgress) -> None:
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
    """A count's rate over the last `window` seconds (its samples older than that dropped);
    None until two samples span some time."""

    def __init__(self, window: float = 10.0) -> None:
        self._window = window
        self._samples: deque[tuple[float, int]] = deque()

    def add(self, now: float, count: int) -> float | None:
        samples = self._samples
        samples.append((now, count))
        while len(samples) > 2 and now - samples[1][0] >= self._window:
            samples.popleft()
        (first_t, first_n), (last_t, last_n) = samples[0], samples[-1]
        return (last_n - first_n) / (last_t - first_t) if last_t > first_t else None


# Columns left free at the end of a line: the terminal echoes Ctrl-C there as "^C", and
# after a line of the full width that echo would wrap, so that the bar's last drawing
# lands on a line of its own below the one it replaces (the bar shown twice).
SPARE_COLUMNS = 2
_MIN_BAR = 10
_REDRAW_EVERY_S = 0.25
_MIN_RETRYING = 16  # "retrying the A…": shorter says nothing


@dataclass(frozen=True, slots=True)
class _Part:
    """One piece of a progress line. As the terminal narrows, the parts of highest
    `drop` go first; `gap` is the space before the part."""

    text: str
    drop: int
    style: str = ""
    gap: str = "  "


@dataclass(frozen=True, slots=True)
class _Line:
    """One bar's line before it is fitted: its label, its counts and what follows the bar."""

    label: str
    done: int
    total: int | None
    parts: tuple[_Part, ...]  # after the bar, in their order on the line
    retrying: str = ""


# The order in which the parts go as the width shrinks (highest first): the request rate
# and the retries first, the count of jobs done never.
_DROP_REQUESTS, _DROP_RETRIES, _DROP_RATE, _DROP_BAR = 8, 7, 6, 5
_DROP_RETRYING, _DROP_ETA, _DROP_PERCENT, _KEEP = 4, 3, 2, 0


@dataclass(frozen=True, slots=True)
class Fitted:
    """A line as it fits the width: the label, the bar's width (0: no bar) and the parts
    that stayed, the retrying origin last, cut with an ellipsis where it had to be."""

    label: str
    bar_width: int
    parts: tuple[_Part, ...]

    @property
    def width(self) -> int:
        bar = 1 + self.bar_width if self.bar_width else 0
        return len(self.label) + bar + sum(len(p.gap) + len(p.text) for p in self.parts)


def fit_line(line: _Line, width: int, *, label_width: int = 0) -> Fitted:
    """`line` in at most `width` columns: the bar takes the room the other parts leave (at
    least 10 columns, or it goes), the retrying origin is cut with an ellipsis, and parts
    go in their `drop` order until the rest fits; the label and the count always stay."""
    label = line.label.rjust(label_width)
    parts = list(line.parts)
    retrying = f"retrying {line.retrying}" if line.retrying else ""
    bar = True

    def needed() -> int:
        fixed = len(label) + sum(len(p.gap) + len(p.text) for p in parts)
        fixed += 1 + _MIN_BAR if bar else 0
        fixed += 2 + min(len(retrying), _MIN_RETRYING) if retrying else 0
        return fixed

    while needed() > width:
        drops = [p.drop for p in parts]
        drops += [_DROP_BAR] if bar else []
        drops += [_DROP_RETRYING] if retrying else []
        worst = max(drops)
        if worst == _KEEP:
            if label == line.label:
                break  # only the label and the count are left: the caller cuts the line
            label = line.label  # no room to align it with the line above
            continue
        if bar and worst == _DROP_BAR:
            bar = False
        elif retrying and worst == _DROP_RETRYING:
            retrying = ""
        else:
            parts.remove(next(p for p in parts if p.drop == worst))
    spare = max(width - needed(), 0)
    if retrying:
        room = min(len(retrying), _MIN_RETRYING + spare)
        spare -= room - min(len(retrying), _MIN_RETRYING)
        shown = retrying if room >= len(retrying) else retrying[: room - 1] + "…"
        parts.append(_Part(shown, _DROP_RETRYING, "yellow"))
    return Fitted(label, _MIN_BAR + spare if bar else 0, tuple(parts))


def _eta(done: int, total: int | None, rate: float | None) -> str:
    """rich's format, whole seconds up: ``0:00:30``, or ``-:--:--`` without an estimate."""
    if total is not None and done >= total:
        return "0:00:00"
    if total is None or not rate:
        return "-:--:--"
    return str(timedelta(seconds=math.ceil((total - done) / rate)))


def _counts(done: int, total: int | None, unit: str, rate: float | None) -> list[_Part]:
    """count, percentage, rate and ETA: the parts of every bar's line."""
    shown_total = f"{total:,}" if total is not None else "?"
    count = f"{done:,}".rjust(len(shown_total)) + f"/{shown_total}"
    parts = [_Part(count, _KEEP, "progress.download", gap=" ")]
    if total:
        parts.append(
            _Part(f"{100 * done / total:>3.0f}%", _DROP_PERCENT, "progress.percentage", " ")
        )
    rate_text = f"{rate:,.1f}" if rate is not None else "?"
    parts.append(_Part(f"{rate_text} {unit}/s", _DROP_RATE))
    parts.append(_Part(f"ETA {_eta(done, total, rate)}", _DROP_ETA, "progress.remaining"))
    return parts


class TerminalProgress:
    """A progress bar on `stream`, for a terminal; `force_terminal` draws it on any
    stream (tests). A rich live display, so that log lines print above it, redrawn at an
    update at most 4 times a second (the fetch updates at least once a second); each line
    fitted to the terminal's width as it is then, parts dropped as it narrows
    (`fit_line`), so that nothing ever wraps."""

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
        self._jobs = _Rate(window=30.0)
        self._batches = _Rate(window=30.0)
        self._live: Live | None = None
        self._drawn = float("-inf")
        # Replaced whole at each update, never changed: rich may draw it from the thread
        # that prints a log line.
        self._lines: tuple[_Line, ...] = ()

    def update(self, snapshot: FetchProgress) -> None:
        self._lines = self._lines_of(snapshot)
        now = self._clock()
        if self._live is None:
            self._live = self._start()  # drawn first with this snapshot's total
            self._drawn = now
        elif now - self._drawn >= _REDRAW_EVERY_S:
            self._live.refresh()
            self._drawn = now

    def _lines_of(self, snapshot: FetchProgress) -> tuple[_Line, ...]:
        now = self._clock()
        lines = []
        if snapshot.batches_done is not None:  # a report's batches above its jobs
            done, total = snapshot.batches_done, snapshot.batches_total
            rate = self._batches.add(now, done)
            lines.append(
                _Line("batches", done, total, tuple(_counts(done, total, "batches", rate)))
            )
        done, total = snapshot.jobs_done, snapshot.total
        rate = self._jobs.add(now, done)
        requests = self._requests.add(now, snapshot.requests) or 0.0
        retries = "retry" if snapshot.retries == 1 else "retries"
        parts = [
            *_counts(done, total, self._label, rate),
            _Part(f"{requests:,.0f} req/s", _DROP_REQUESTS),
            _Part(f"{snapshot.retries:,} {retries}", _DROP_RETRIES),
        ]
        lines.append(_Line(self._label, done, total, tuple(parts), snapshot.retrying))
        return tuple(lines)

    def _start(self) -> Live:
        # rich costs tens of milliseconds to import: paid at the first job, not at start-up.
        from rich.console import Console
        from rich.live import Live

        console = Console(file=self._stream, force_terminal=self._force)
        live = Live(
            console=console, auto_refresh=False, get_renderable=lambda: _Screen(self._lines)
        )
        live.start(refresh=True)
        return live

    def close(self) -> None:
        if self._live is not None:
            self._live.stop()  # leaves the last drawing in place, above what follows
            self._live = None


class _Screen:
    """The bars' lines as rich draws them: each fitted to the console's width now."""

    def __init__(self, lines: tuple[_Line, ...]) -> None:
        self._lines = lines

    def __rich_console__(self, console: Console, options: ConsoleOptions) -> RenderResult:
        from rich.progress_bar import ProgressBar
        from rich.text import Text

        width = options.max_width - SPARE_COLUMNS
        label_width = max((len(line.label) for line in self._lines), default=0)
        for line in self._lines:
            fitted = fit_line(line, width, label_width=label_width)
            text = Text(fitted.label, style="progress.description", no_wrap=True)
            if fitted.bar_width:
                bar = ProgressBar(total=line.total, completed=line.done, width=fitted.bar_width)
                text.append(" ")
                for segment in console.render(bar, options.update_width(fitted.bar_width)):
                    text.append(segment.text, segment.style)
            for part in fitted.parts:
                text.append(part.gap)
                text.append(part.text, part.style or None)
            text.truncate(width, overflow="ellipsis")  # a terminal too narrow for the count
            yield text


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

    def update(self, snapshot: FetchProgress) -> None:
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


class RecordingProgress:
    """A Progress that records the last FetchProgress it was given, for the line that an
    interrupted run ends with; it passes every update on to the display it wraps."""

    def __init__(self, shown: Progress | None = None) -> None:
        self._shown = shown or NoProgress()
        self.last = FetchProgress(jobs_done=0, jobs_listed=0)

    @property
    def done(self) -> int:
        return self.last.jobs_done

    @property
    def listed(self) -> int:
        return self.last.jobs_listed

    def update(self, snapshot: FetchProgress) -> None:
        self.last = snapshot
        self._shown.update(snapshot)

    def close(self) -> None:
        self._shown.close()
