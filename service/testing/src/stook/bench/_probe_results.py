"""What `stook bench --probe` concludes and writes: the recommendation, probe.json, the CSV,
the plot, the table and the `[fetch]` lines.

The recommendation is the smallest level that gives nearly all the throughput the server
gave without throttling or queueing: of the levels with no 429 and a p95 latency at most
`P95_GROWTH` times the lowest level's, the smallest within `NEAR_BEST` of the best of them
in requests per second. More concurrency than that only queues requests at the server
(or gets them refused).
"""

from __future__ import annotations

import csv
import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

from stook.bench._probe_level import LevelResult

__all__ = [
    "ERROR_RATE_LIMIT",
    "ProbeResult",
    "fetch_lines",
    "recommend",
    "stops_climb",
    "write_results",
]

# Within 10 % of the best level's requests per second counts as the best.
NEAR_BEST: Final = 0.9
# A level whose p95 latency is more than twice the lowest level's is queueing requests.
P95_GROWTH: Final = 2.0
# A level with more 5xx answers (and failed calls) than this share of its requests stops
# the climb: the server is failing, not merely slower.
ERROR_RATE_LIMIT: Final = 0.03

_CSV_COLUMNS: Final = (
    "concurrency",
    "seconds",
    "requests",
    "requests_per_s",
    "p50_ms",
    "p95_ms",
    "p99_ms",
    "api_p50_ms",
    "api_p95_ms",
    "api_p99_ms",
    "storage_p50_ms",
    "storage_p95_ms",
    "storage_p99_ms",
    "throttled",
    "errors",
    "retries",
)


def stops_climb(level: LevelResult) -> str | None:
    """Why the probe climbs no higher after `level`, or None if it may."""
    if level.throttled:
        return f"throttled at concurrency {level.concurrency} ({level.throttled} answers 429)"
    if level.error_rate > ERROR_RATE_LIMIT:
        return (
            f"errors at concurrency {level.concurrency}: {level.errors} of "
            f"{level.requests} requests ({level.error_rate:.0%})"
        )
    return None


def recommend(levels: Sequence[LevelResult]) -> int | None:
    """The recommended concurrency (see the module's docstring); None when no level
    qualifies (the lowest was throttled, failing, or answered nothing)."""
    lowest_p95 = min(levels, key=lambda level: level.concurrency).p95_ms if levels else None
    calm = [
        level
        for level in levels
        if stops_climb(level) is None
        and level.requests_per_s > 0
        and level.p95_ms is not None
        and (lowest_p95 is None or level.p95_ms <= P95_GROWTH * lowest_p95)
    ]
    if not calm:
        return None
    best = max(level.requests_per_s for level in calm)
    return min(level.concurrency for level in calm if level.requests_per_s >= NEAR_BEST * best)


@dataclass(frozen=True, slots=True)
class ProbeResult:
    """The whole probe: its levels, why it stopped climbing, and what it recommends."""

    kind: str  # "batch" or "report"
    levels: tuple[LevelResult, ...]
    recommended_concurrency: int | None
    stopped: str | None  # why the climb stopped early; None if every level ran
    interrupted: bool = False

    def as_dict(self) -> dict[str, Any]:
        return {
            "kind": self.kind,
            "levels": [level.as_dict() for level in self.levels],
            "recommended_concurrency": self.recommended_concurrency,
            "stopped": self.stopped,
            "interrupted": self.interrupted,
        }


def fetch_lines(result: ProbeResult) -> str:
    """The `[fetch]` lines to paste into stook.toml (a comment when there is nothing to
    recommend)."""
    if result.recommended_concurrency is None:
        return (
            "# stook bench --probe: no level qualified; probe lower levels (--levels 1,2,4)\n"
            "[fetch]\n"
        )
    chosen = next(lv for lv in result.levels if lv.concurrency == result.recommended_concurrency)
    return (
        f"# stook bench --probe: {chosen.requests_per_s:g} requests/s, "
        f"p95 {chosen.p95_ms:g} ms at this concurrency\n"
        "[fetch]\n"
        f"concurrency = {chosen.concurrency}\n"
    )


def write_results(result: ProbeResult, out: Path, *, plot: bool = True) -> list[Path]:
    """probe.json, probe.csv and (with `plot` and matplotlib) probe.png into `out`."""
    out.mkdir(parents=True, exist_ok=True)
    written = [out / "probe.json", out / "probe.csv"]
    written[0].write_text(json.dumps(result.as_dict(), indent=2) + "\n", encoding="utf-8")
    with written[1].open("w", newline="", encoding="utf-8") as file:
        writer = csv.writer(file)
        writer.writerow(_CSV_COLUMNS)
        for level in result.levels:
            writer.writerow(_blank_none(_csv_row(level)))
    from stook.bench._plots import plots_available

    if plot and plots_available() and result.levels:
        written.append(_write_plot(result, out / "probe.png"))
    return written


def _csv_row(level: LevelResult) -> tuple[Any, ...]:
    return (
        level.concurrency,
        level.seconds,
        level.requests,
        level.requests_per_s,
        level.p50_ms,
        level.p95_ms,
        level.p99_ms,
        level.api.p50_ms,
        level.api.p95_ms,
        level.api.p99_ms,
        level.storage.p50_ms,
        level.storage.p95_ms,
        level.storage.p99_ms,
        level.throttled,
        level.errors,
        level.retries,
    )


def _blank_none(row: tuple[Any, ...]) -> list[Any]:
    return ["" if value is None else value for value in row]


def _write_plot(result: ProbeResult, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")  # files only; no display needed
    import matplotlib.pyplot as plt

    levels = sorted(result.levels, key=lambda level: level.concurrency)
    xs = [level.concurrency for level in levels]
    fig, throughput = plt.subplots(figsize=(6.4, 4.2))
    throughput.plot(
        xs, [lv.requests_per_s for lv in levels], "o-", color="tab:blue", label="requests/s"
    )
    throughput.set_xscale("log", base=2)
    throughput.set_xticks(xs, [str(x) for x in xs])
    throughput.set_xlabel("concurrency")
    throughput.set_ylabel("requests/s", color="tab:blue")
    throughput.set_ylim(bottom=0)
    latency = throughput.twinx()
    latency.plot(xs, [lv.p95_ms or 0.0 for lv in levels], "s--", color="tab:orange", label="p95 ms")
    latency.set_ylabel("p95 latency, ms", color="tab:orange")
    latency.set_ylim(bottom=0)
    throttled = [level for level in levels if level.throttled]
    if throttled:
        throughput.plot(
            [level.concurrency for level in throttled],
            [level.requests_per_s for level in throttled],
            "X",
            color="tab:red",
            markersize=10,
            linestyle="none",
            label="answered 429",
        )
    if result.recommended_concurrency is not None:
        throughput.axvline(
            result.recommended_concurrency, color="grey", linestyle=":", label="recommended"
        )
    handles, labels = throughput.get_legend_handles_labels()
    more_handles, more_labels = latency.get_legend_handles_labels()
    throughput.legend(handles + more_handles, labels + more_labels, loc="lower right")
    throughput.set_title(f"stook bench --probe ({result.kind} mode)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
