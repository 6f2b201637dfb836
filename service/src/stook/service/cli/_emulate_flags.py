"""`stook emulate`'s first-class knobs: where it serves, and how badly it behaves.

Only the flags are here (the parser is built without stook-testing installed); the
emulator's CLI (`stook.emulator._cli.settings_from`) turns them into its settings.
"""

from __future__ import annotations

import argparse


def add_emulate_flags(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--report-inputs",
        metavar="DIR",
        help="write report_config.json, naming this emulator, into this inputs folder",
    )
    parser.add_argument(
        "--host",
        default="127.0.0.1",
        metavar="ADDR",
        help="the address to listen on; 0.0.0.0 serves other machines and containers",
    )
    parser.add_argument(
        "--public-host",
        metavar="NAME",
        help="the host name its URLs and the written configs use, as clients reach it "
        "(e.g. host.docker.internal); default: --host, or 127.0.0.1 for 0.0.0.0 and ::",
    )
    faults = parser.add_argument_group(
        "faults and limits",
        "Fault flags are fractions of requests (0 to 1), on the API and storage alike.",
    )
    faults.add_argument(
        "--fault-5xx", type=float, default=0.0, metavar="FRACTION", help="answered 500/502/503"
    )
    faults.add_argument(
        "--fault-429",
        type=float,
        default=0.0,
        metavar="FRACTION",
        help="answered 429 with a Retry-After",
    )
    faults.add_argument(
        "--fault-reset",
        type=float,
        default=0.0,
        metavar="FRACTION",
        help="connection reset before answering",
    )
    faults.add_argument(
        "--rate-limit",
        type=float,
        metavar="RPS",
        help="API requests per second before it answers 429 (default: unlimited)",
    )
    faults.add_argument(
        "--storage-rate-limit",
        type=float,
        metavar="RPS",
        help="storage requests per second before it answers 429 (default: unlimited)",
    )
    faults.add_argument(
        "--broken-jobs",
        metavar="I,J,...",
        help="indices (from 0) of batch jobs whose listings always answer 500: "
        "with --allow-missing-jobs they are left out, without it the run exits 3",
    )
