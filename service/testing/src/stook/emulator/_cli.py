"""`stook emulate`: serve the ReSim API emulator until interrupted."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from stook.emulator._config import EmulatorConfig
from stook.emulator._server import serve_with_inputs
from stook.service.modes import ConfigError


def settings_from(args: argparse.Namespace) -> EmulatorConfig:
    """The emulator's settings: the named flags, then every `--set KEY=VALUE` in order.

    Raises ConfigError (exit 2) naming the setting that is malformed, unknown or invalid.
    """
    values: dict[str, Any] = {
        "seed": args.seed,
        "jobs_per_batch": args.jobs,
        "report_batches": args.batches,
        "latency_ms": args.latency_ms,
    }
    # The first-class knobs (getattr: a namespace built by hand may lack them).
    for flag, key in (
        ("fault_5xx", "fault_5xx"),
        ("fault_429", "fault_429"),
        ("fault_reset", "fault_reset"),
        ("rate_limit", "rate_limit_rps"),
        ("storage_rate_limit", "storage_rate_limit_rps"),
    ):
        value = getattr(args, flag, None)
        if value:
            values[key] = value
    broken = getattr(args, "broken_jobs", None)
    if broken:
        values["broken_jobs"] = _indices("--broken-jobs", broken)
    for item in getattr(args, "set", None) or []:
        key, equals, text = item.partition("=")
        key = key.strip()
        if not equals or not key:
            raise ConfigError(f"--set {item!r}: expected KEY=VALUE")
        try:
            values[key] = json.loads(text)
        except json.JSONDecodeError:
            values[key] = text  # a bare word: a string setting such as the token
    try:
        return EmulatorConfig.from_dict(values)
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"emulator settings: {exc}") from None


def _indices(flag: str, text: str) -> tuple[int, ...]:
    try:
        return tuple(int(part) for part in text.split(",") if part.strip())
    except ValueError:
        raise ConfigError(f"{flag} {text!r}: expected indices such as 3,17") from None


async def emulate(args: argparse.Namespace) -> int:
    report_inputs = getattr(args, "report_inputs", None)
    await serve_with_inputs(
        settings_from(args),
        host=getattr(args, "host", "127.0.0.1"),
        public_host=getattr(args, "public_host", None),
        api_port=args.api_port,
        storage_port=args.storage_port,
        inputs_dir=Path(args.inputs) if args.inputs else None,
        report_inputs_dir=Path(report_inputs) if report_inputs else None,
    )
    return 0
