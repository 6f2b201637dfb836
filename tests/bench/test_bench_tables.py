"""The Markdown tables `stook bench` writes next to its CSV."""

from __future__ import annotations

from typing import Any

from stook.bench._tables import sweep_tables


def _row(client: str, latency: float, concurrency: int, seconds: float, **extra: Any) -> Any:
    requests = 300
    return {
        "client": client,
        "concurrency": concurrency,
        "latency_ms": latency,
        "jobs": 100,
        "seconds": seconds,
        "requests": requests,
        "requests_per_second": requests / seconds,
        "retries": 0,
        "peak_rss_mb": 80.4,
        "client_cpu_us_per_request": 400,
        "server_cpu_us_per_request": None,
        "side_by_side": False,
        **extra,
    }


def test_rows_give_ratios_against_the_bare_loop_and_the_bound() -> None:
    rows = [
        _row("stook", 10.0, 64, 0.12, side_by_side=True),
        _row("bare aiohttp loop", 10.0, 64, 0.10),
        _row("latency bound", 10.0, 64, 0.05),
        _row("resim fetch_job_metrics_by_batch", 10.0, 64, 1.2),
        _row("stook", 0.0, 4, 0.5),
    ]
    sweep, resim = sweep_tables(rows).strip().split("\n\n")
    lines = sweep.splitlines()
    assert lines[0].startswith("| latency | jobs | concurrency | stook s |")
    zero, ten = lines[2], lines[3]  # sorted by latency
    # At 0 ms there is no bound and here no bare run: dashes, not zeros.
    assert zero.startswith("| 0 ms | 100 | 4 | 0.50 | 600 | – | – | – | – | – | – |")
    # 0.12 s against a 0.05 s bound is 2.40x; the bare loop's 0.10 s is 2.00x.
    assert ten.startswith(
        "| 10 ms | 100 | 64 | 0.12 ‡ | 2,500 | 0.10 | 3,000 | 0.83 | 0.05 | 2.40 | 2.00 |"
    )
    assert resim.splitlines()[2] == "| 10 ms | 100 | 1.20 | 250 | 80 | 0.12 | 10.0x |"


def test_no_resim_rows_no_resim_table() -> None:
    assert "\n\n" not in sweep_tables([_row("stook", 0.0, 1, 1.0)]).strip()
