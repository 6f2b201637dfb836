"""The sweep as Markdown tables, written next to the CSV so that docs quote numbers, not copies.

One row per (latency, jobs, concurrency) point: stook against the bare aiohttp loop and the
latency bound, and a second table for ReSim's fetcher where it ran.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any, Final

from stook.bench._measure import BARE_LOOP, LATENCY_BOUND, RESIM, STOOK

__all__ = ["sweep_tables"]


_SWEEP_HEADER: Final = (
    "latency",
    "jobs",
    "concurrency",
    "stook s",
    "stook req/s",
    "bare loop s",
    "bare req/s",
    "stook / bare (req/s)",
    "latency bound s",
    "stook / bound",
    "bare / bound",
    "retries",
    "stook peak RSS MB",
    "client CPU µs/req (stook / bare)",
    "server CPU µs/req (stook run)",
)
_RESIM_HEADER: Final = (
    "latency",
    "jobs",
    "ReSim s",
    "ReSim req/s",
    "ReSim peak RSS MB",
    "stook s (c=64)",
    "stook faster by",
)


def sweep_tables(rows: list[dict[str, Any]]) -> str:
    """Markdown for the sweep's rows (as `stook bench` writes them to sweep.csv)."""
    index = {(r["client"], r["latency_ms"], r["jobs"], r["concurrency"]): r for r in rows}
    points = sorted(
        {(r["latency_ms"], r["jobs"], r["concurrency"]) for r in rows if r["client"] == STOOK}
    )
    sweep = []
    for latency, jobs, concurrency in points:
        stook = index[(STOOK, latency, jobs, concurrency)]
        bare = index.get((BARE_LOOP, latency, jobs, concurrency))
        bound = index.get((LATENCY_BOUND, latency, jobs, concurrency))
        shared = " ‡" if stook.get("side_by_side") else ""
        sweep.append(
            (
                f"{latency:g} ms",
                str(jobs),
                str(concurrency),
                f"{stook['seconds']:.2f}{shared}",
                _number(stook["requests_per_second"]),
                _seconds(bare),
                _number(bare["requests_per_second"]) if bare else "–",
                _ratio(stook["requests_per_second"], bare["requests_per_second"] if bare else None),
                _seconds(bound) if latency else "–",
                _ratio(stook["seconds"], bound["seconds"] if bound and latency else None),
                _ratio(
                    bare["seconds"] if bare else None,
                    bound["seconds"] if bound and latency else None,
                ),
                str(stook["retries"]),
                f"{stook['peak_rss_mb']:.0f}",
                f"{_number(stook['client_cpu_us_per_request'])} / "
                f"{_number(bare['client_cpu_us_per_request']) if bare else '–'}",
                _number(stook.get("server_cpu_us_per_request")),
            )
        )
    resim = []
    for (client, latency, jobs, _c), row in sorted(index.items(), key=lambda kv: kv[0][1:3]):
        if client != RESIM:
            continue
        at_64 = index.get((STOOK, latency, jobs, 64))
        resim.append(
            (
                f"{latency:g} ms",
                str(jobs),
                f"{row['seconds']:.2f}",
                _number(row["requests_per_second"]),
                f"{row['peak_rss_mb']:.0f}",
                f"{at_64['seconds']:.2f}" if at_64 else "–",
                f"{row['seconds'] / at_64['seconds']:.1f}x" if at_64 else "–",
            )
        )
    parts = [_table(_SWEEP_HEADER, sweep)]
    if resim:
        parts.append(_table(_RESIM_HEADER, resim))
    return "\n\n".join(parts) + "\n"


def _table(header: tuple[str, ...], rows: Iterable[tuple[str, ...]]) -> str:
    lines = ["| " + " | ".join(header) + " |", "|" + "---:|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in rows]
    return "\n".join(lines)


def _seconds(row: dict[str, Any] | None) -> str:
    return f"{row['seconds']:.2f}" if row else "–"


def _number(value: float | None) -> str:
    return "–" if value is None else f"{value:,.0f}"


def _ratio(a: float | None, b: float | None) -> str:
    return f"{a / b:.2f}" if a is not None and b else "–"
