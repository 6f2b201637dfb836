"""The `stook` command: run (the metrics-build entry point), demo, emulate, validate, show."""

from __future__ import annotations

import argparse
import asyncio
import os
import sys
import traceback
from collections.abc import Sequence
from pathlib import Path

import structlog

from stook.service._logging import configure_logging
from stook.service._run import ExitCode, exit_code_for, explain, resolve_options, run
from stook.service._test_mode import UserFunctionError

log = structlog.get_logger("stook.cli")


def _add_logging(parser: argparse.ArgumentParser, *, default_level: str = "info") -> None:
    parser.add_argument(
        "--log-level",
        default=os.environ.get("STOOK_LOG_LEVEL", default_level),
        choices=["debug", "info", "warning", "error"],
        help="log level (env STOOK_LOG_LEVEL; default info)",
    )
    parser.add_argument(
        "--log-format",
        default=os.environ.get("STOOK_LOG_FORMAT", "auto"),
        choices=["auto", "json", "console"],
        help="JSON lines or console lines; auto picks JSON when stderr is not a terminal",
    )


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="stook",
        description="Fast aggregation of ReSim test, batch and report metrics.",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    run_p = sub.add_parser(
        "run",
        help="the metrics-build entry point: detect test, batch or report mode and run it",
        description="Detect the mode from the inputs folder and write OUTPUTS/metrics.binproto.",
    )
    run_p.add_argument("--inputs", help="inputs folder (env STOOK_INPUTS; /tmp/resim/inputs)")
    run_p.add_argument("--outputs", help="outputs folder (env STOOK_OUTPUTS; /tmp/resim/outputs)")
    run_p.add_argument("--config", help="stook.toml (env STOOK_CONFIG; ./stook.toml if present)")
    run_p.add_argument(
        "--allow-missing-jobs",
        type=float,
        metavar="FRACTION",
        help="tolerate up to this share of jobs whose data stays unavailable (default 0)",
    )
    run_p.add_argument(
        "--project-id", help="project for batch configs that lack projectID (env STOOK_PROJECT_ID)"
    )
    _add_logging(run_p)

    demo_p = sub.add_parser("demo", help="run batch mode against the built-in emulator")
    demo_p.add_argument("--jobs", type=int, default=200, help="jobs in the emulated batch")
    demo_p.add_argument("--output", default="demo-output", help="where to write the output")
    demo_p.add_argument("--seed", type=int, default=7)
    _add_logging(demo_p, default_level="warning")

    emulate_p = sub.add_parser("emulate", help="serve the ReSim API emulator on loopback")
    emulate_p.add_argument("--jobs", type=int, default=200, help="jobs per batch")
    emulate_p.add_argument("--batches", type=int, default=12, help="batches in the report")
    emulate_p.add_argument("--seed", type=int, default=7)
    emulate_p.add_argument("--latency-ms", type=float, default=0.0)
    emulate_p.add_argument("--api-port", type=int, default=0)
    emulate_p.add_argument("--storage-port", type=int, default=0)
    emulate_p.add_argument(
        "--inputs", help="also write the platform's config files into this inputs folder"
    )
    _add_logging(emulate_p)

    bench_p = sub.add_parser("bench", help="measure batch mode against the emulator and ReSim")
    bench_p.add_argument("--quick", action="store_true", help="small sizes; a smoke test")
    bench_p.add_argument("--out", default="docs/benchmarks", help="where results are written")

    validate_p = sub.add_parser("validate", help="check a metrics.binproto against every rule")
    validate_p.add_argument("file", type=Path)

    show_p = sub.add_parser("show", help="print a summary of a metrics.binproto")
    show_p.add_argument("file", type=Path)
    return parser


def main(argv: Sequence[str] | None = None) -> None:
    sys.exit(run_cli(argv))


def run_cli(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if hasattr(args, "log_format"):
        json_logs = None if args.log_format == "auto" else args.log_format == "json"
        configure_logging(json=json_logs, level=args.log_level)
    else:
        # Commands without logging flags still log to stderr, never onto their stdout.
        configure_logging(level="warning")
    try:
        return _dispatch(args)
    except KeyboardInterrupt:
        return 130
    except Exception as error:
        code = exit_code_for(error)
        if isinstance(error, UserFunctionError) and error.__cause__ is not None:
            traceback.print_exception(error.__cause__)
        elif code is ExitCode.UNEXPECTED:
            traceback.print_exception(error)
        message = explain(error)
        log.error("stook failed", error=message, exit_code=int(code))
        print(f"stook: error: {message}", file=sys.stderr)
        return int(code)


def _dispatch(args: argparse.Namespace) -> int:
    match args.command:
        case "run":
            options = resolve_options(
                inputs=args.inputs,
                outputs=args.outputs,
                config=args.config,
                allow_missing_jobs=args.allow_missing_jobs,
                project_id=args.project_id,
            )
            asyncio.run(run(options))
            return 0
        case "demo":
            from stook.service._demo import run_demo

            return run_demo(jobs=args.jobs, output=Path(args.output), seed=args.seed)
        case "emulate":
            from stook.service._emulate_cli import emulate

            return asyncio.run(emulate(args))
        case "bench":
            from stook.service.bench import run_bench

            run_bench(Path(args.out), quick=args.quick)
            return 0
        case "validate":
            from stook.service._inspect import validate_file

            return validate_file(args.file)
        case "show":
            from stook.service._inspect import show_file

            return show_file(args.file)
    raise AssertionError(f"unhandled command {args.command!r}")  # argparse restricts it
