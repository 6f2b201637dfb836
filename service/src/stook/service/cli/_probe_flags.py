"""`stook bench --probe`'s flags, and the step from them to the probe (stook.bench).

The flags are here so that the parser is built without stook-testing installed; the
inputs and stook.toml are found as `stook run` finds them (flags, then STOOK_INPUTS and
STOOK_CONFIG, then the platform's defaults and ./stook.toml).
"""

from __future__ import annotations

import argparse
from typing import Any

_DEFAULT_LEVELS = "4,8,16,32,64,128"


def _levels(text: str) -> list[int]:
    try:
        levels = [int(part) for part in text.split(",") if part.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r} is not a comma-separated list of whole numbers"
        ) from None
    if not levels or any(level < 1 for level in levels):
        raise argparse.ArgumentTypeError(f"{text!r}: each level must be at least 1")
    if len(set(levels)) != len(levels):
        raise argparse.ArgumentTypeError(f"{text!r} names a level twice")
    return sorted(levels)


def _positive(kind: type[int] | type[float]) -> Any:
    def parse(text: str) -> int | float:
        try:
            value = kind(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not value > 0:
            raise argparse.ArgumentTypeError(f"{text!r} must be positive")
        return value

    return parse


def add_probe_flags(parser: argparse.ArgumentParser) -> None:
    group = parser.add_argument_group(
        "probe",
        "--probe: measure your own ReSim API with a run's own read-only requests, climbing "
        "through the concurrency levels, and recommend [fetch] concurrency (docs/probe.md)",
    )
    group.add_argument(
        "--probe",
        action="store_true",
        help="probe the API of the inputs' batch or report instead of benchmarking stook",
    )
    group.add_argument(
        "--inputs",
        metavar="DIR",
        help="inputs folder with batch_metrics_config.json or report_config.json "
        "(env STOOK_INPUTS; default /tmp/resim/inputs)",
    )
    group.add_argument(
        "--config",
        metavar="FILE",
        help="stook.toml: its aggregations and [fetch] (env STOOK_CONFIG; default "
        "./stook.toml if present)",
    )
    group.add_argument(
        "--project-id",
        metavar="UUID",
        help="project for batch configs that lack projectID (env STOOK_PROJECT_ID)",
    )
    group.add_argument(
        "--levels",
        type=_levels,
        metavar="N,N,...",
        help=f"the concurrency levels, climbed in order (default {_DEFAULT_LEVELS})",
    )
    group.add_argument(
        "--seconds-per-level",
        type=_positive(float),
        metavar="S",
        help="the longest a level runs (default 10)",
    )
    group.add_argument(
        "--max-requests",
        type=_positive(int),
        metavar="N",
        help="the most requests a level sends (default 2000)",
    )


_PROBE_ONLY = {
    "inputs": "--inputs",
    "config": "--config",
    "project_id": "--project-id",
    "levels": "--levels",
    "seconds_per_level": "--seconds-per-level",
    "max_requests": "--max-requests",
}


def check_probe_flags(args: argparse.Namespace) -> None:
    """A probe's flag without --probe is a mistake, not something to ignore (exit 2)."""
    from stook.service.cli._usage import UsageError

    if args.probe:
        if args.quick or args.engines:
            raise UsageError("--probe measures your API: it takes neither --quick nor --engines")
        return
    given = [flag for name, flag in _PROBE_ONLY.items() if getattr(args, name) is not None]
    if given:
        raise UsageError(f"{given[0]} is a flag of 'stook bench --probe'; add --probe")


def run_probe(bench: Any, args: argparse.Namespace) -> int:
    """Read the plan (exit 2 for bad inputs or config), then probe on a fresh loop."""
    from pathlib import Path

    from stook.service.cli import _signals
    from stook.service.cli._run import resolve_options

    options = resolve_options(
        inputs=args.inputs,
        outputs=None,
        config=args.config,
        allow_missing_jobs=None,
        project_id=args.project_id,
    )
    plan = bench.read_plan(options.inputs, options.config, options.project_id)
    _signals.run(
        bench.probe(
            plan,
            Path(args.out or "probe-results"),
            levels=args.levels or _levels(_DEFAULT_LEVELS),
            seconds_per_level=args.seconds_per_level or 10.0,
            max_requests=args.max_requests or 2_000,
        )
    )
    return 0
