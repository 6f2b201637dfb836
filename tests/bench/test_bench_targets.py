"""How `stook bench` judges its targets from the sweep and from the repeated target points."""

from __future__ import annotations

from typing import Any

from stook.bench._suite import evaluate_targets
from stook.bench._sweep import FULL


def _row(client: str, latency: float, seconds: float) -> dict[str, Any]:
    return {
        "client": client,
        "concurrency": 64,
        "latency_ms": latency,
        "jobs": 1000,
        "seconds": seconds,
        "requests_per_second": 3000 / seconds,
    }


SWEEP = [
    _row("stook", 0.0, 1.5),
    _row("bare aiohttp loop", 0.0, 1.0),
    _row("stook", 10.0, 1.2),
    _row("bare aiohttp loop", 10.0, 1.0),
    _row("latency bound", 10.0, 0.5),
]


def test_the_sweep_alone_decides_without_repeats() -> None:
    targets = evaluate_targets(SWEEP, FULL, None)
    assert targets["share_of_bare_loop"]["measured"] == 0.67
    assert not targets["share_of_bare_loop"]["met"]
    assert targets["latency_bound"]["measured"] == 2.4
    assert targets["latency_bound"]["bare_loop"] == 2.0


def test_repeated_medians_decide_and_the_single_run_is_kept() -> None:
    repeated: list[dict[str, Any]] = [
        {
            "latency_ms": 0.0,
            "jobs": 1000,
            "concurrency": 64,
            "repeats": 5,
            "stook_share_of_bare": 0.72,
            "stook_over_bound": None,
            "bare_over_bound": None,
        },
        {
            "latency_ms": 10.0,
            "jobs": 1000,
            "concurrency": 64,
            "repeats": 5,
            "stook_share_of_bare": 0.9,
            "stook_over_bound": 2.2,
            "bare_over_bound": 2.0,
        },
    ]
    targets = evaluate_targets(SWEEP, FULL, None, repeated)
    share = targets["share_of_bare_loop"]
    assert (share["measured"], share["sweep_single_run"], share["met"]) == (0.72, 0.67, True)
    assert share["how"] == "median of 5 runs each"
    bound = targets["latency_bound"]
    assert (bound["measured"], bound["sweep_single_run"], bound["met"]) == (2.2, 2.4, False)
