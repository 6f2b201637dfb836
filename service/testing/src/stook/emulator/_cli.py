"""`stook emulate`: serve the ReSim API emulator on loopback until interrupted."""

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


async def emulate(args: argparse.Namespace) -> int:
    await serve_with_inputs(
        settings_from(args),
        api_port=args.api_port,
        storage_port=args.storage_port,
        inputs_dir=Path(args.inputs) if args.inputs else None,
    )
    return 0
