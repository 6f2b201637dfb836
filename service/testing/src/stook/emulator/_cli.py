"""`stook emulate`: serve the ReSim API emulator on loopback until interrupted."""

from __future__ import annotations

import argparse
from pathlib import Path

from stook.emulator import EmulatorConfig, serve_with_inputs


async def emulate(args: argparse.Namespace) -> int:
    config = EmulatorConfig(
        seed=args.seed,
        jobs_per_batch=args.jobs,
        report_batches=args.batches,
        latency_ms=args.latency_ms,
    )
    await serve_with_inputs(
        config,
        api_port=args.api_port,
        storage_port=args.storage_port,
        inputs_dir=Path(args.inputs) if args.inputs else None,
    )
    return 0
