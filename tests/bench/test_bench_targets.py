"""How `stook bench` judges its targets from the sweep and from the repeated target points."""

from __future__ import annotations

from typing import Any

from stook.bench._decode import decode_target, measure_decode
from stook.bench._report_compare import report_target
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
            "stook_share_of_bare": 0.88,
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
    assert (share["measured"], share["sweep_single_run"], share["met"]) == (0.88, 0.67, True)
    assert share["how"] == "median of 5 runs each"
    bound = targets["latency_bound"]
    assert (bound["measured"], bound["sweep_single_run"], bound["met"]) == (2.2, 2.4, False)


def test_the_share_target_is_issue_13s() -> None:
    repeated: list[dict[str, Any]] = [
        {"jobs": 1000, "concurrency": 64, "latency_ms": 0.0, "repeats": 5}
        | {"stook_share_of_bare": 0.84},
    ]
    share = evaluate_targets(SWEEP, FULL, None, repeated)["share_of_bare_loop"]
    assert (share["target"], share["met"]) == (">= 0.85", False)


def test_report_mode_is_judged_by_the_median_of_its_runs() -> None:
    runs = [
        {"batches": 50, "jobs_per_batch": 100, "latency_ms": 10.0, "speedup": s}
        for s in (9.1, 12.8, 11.7)
    ]
    target = report_target(runs)["report_vs_resim"]
    assert (target["measured"], target["by_run"], target["met"]) == (11.7, [9.1, 11.7, 12.8], True)
    assert target["at"] == "50 batches x 100 jobs, 10 ms, median of 3"
    without_resim = [{"batches": 5, "jobs_per_batch": 20, "latency_ms": 10.0}]
    assert report_target(without_resim) == {}


def test_decode_is_judged_in_doubles_per_second() -> None:
    decode = {"rounds": 50, "doubles_per_second": 9_990_000}
    target = decode_target(decode)["decode_reduce"]
    assert (target["measured"], target["met"]) == (10.0, False)
    result = measure_decode(rounds=3)
    assert result["doubles_per_second"] > 0
    assert result["jobs"] * result["doubles_per_job"] == 30_000
