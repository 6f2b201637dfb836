"""`stook validate` and `stook show`: look at a metrics.binproto from the command line."""

from __future__ import annotations

import os
import sys
from typing import TextIO

from stook.sdk import (
    InvalidMetricsError,
    JobMetricsView,
    ReadError,
    find_problems,
    read_job_metrics,
)
from stook.service.cli._usage import UsageError
from stook.service.preview import summary_lines

EXIT_INVALID = 4


# A file's name as the user gave it, or a path object.
FileName = str | os.PathLike[str]


def _read(path: FileName) -> JobMetricsView:
    name = os.fspath(path)
    try:
        with open(path, "rb") as file:
            payload = file.read()
    except FileNotFoundError:
        # A file that is not there is the user's to fix (exit 2), not invalid data (4).
        raise UsageError(f"{name!r}: no such file") from None
    except OSError as exc:
        raise ReadError(f"could not read JobMetrics from {name!r}: {exc.strerror}") from None
    return read_job_metrics(payload, source=name)


def validate_file(path: FileName, out: TextIO | None = None) -> int:
    """Print every rule the file breaks; exit 0 when there is none, 4 otherwise."""
    stream = out or sys.stdout
    view = _read(path)
    problems = find_problems(view.raw)
    if not problems:
        print(
            f"{path}: valid ({len(view.metrics)} metrics, {len(view.data)} metrics data)",
            file=stream,
        )
        return 0
    for problem in problems:
        print(f"{path}: {problem}", file=stream)
    raise InvalidMetricsError(problems)


def show_file(path: FileName, out: TextIO | None = None, *, full: bool = False) -> int:
    stream = out or sys.stdout
    for text in summary_lines(_read(path), full=full):
        print(text, file=stream)
    return 0
