"""What a preview is made of: each input file (or message) read once, with its findings.

A source is read with the SDK's reader, so a file that is not JobMetrics fails here with
the reader's one-line `ReadError` naming it. The validator's findings are kept, not
raised: a file the platform would refuse still renders what it can, and says why.
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path

from stook.proto import metrics_pb2 as pb
from stook.sdk import JobMetricsView, Problem, ReadError, find_problems, parse_job_metrics
from stook.sdk import read_job_metrics as read_view

PreviewInput = str | os.PathLike[str] | pb.JobMetrics | JobMetricsView
"""A metrics.binproto path, a parsed JobMetrics message, or a reader's view of one."""


@dataclass(frozen=True, slots=True)
class Source:
    label: str
    """The file's name as given, or ``message N`` for a message."""
    size: int
    """Bytes of the file, or of the message serialized."""
    folder: Path | None
    """Where the file's images are looked for; None for a message."""
    view: JobMetricsView
    problems: tuple[Problem, ...]


def load_sources(inputs: Iterable[PreviewInput]) -> list[Source]:
    sources = [_load(item, i) for i, item in enumerate(inputs, start=1)]
    if not sources:
        raise ValueError("a preview needs at least one metrics.binproto file or message")
    return sources


def _load(item: PreviewInput, number: int) -> Source:
    if isinstance(item, JobMetricsView):
        view = item
        return _source(f"message {number}", view.raw.ByteSize(), None, view)
    if isinstance(item, pb.JobMetrics):
        view = parse_job_metrics(item, source=f"message {number}")
        return _source(f"message {number}", item.ByteSize(), None, view)
    path = Path(item)
    try:
        payload = path.read_bytes()
    except FileNotFoundError:
        raise
    except OSError as exc:
        raise ReadError(f"could not read JobMetrics from {str(path)!r}: {exc.strerror}") from None
    view = read_view(payload, source=str(path))
    return _source(str(path), len(payload), path.parent, view)


def _source(label: str, size: int, folder: Path | None, view: JobMetricsView) -> Source:
    return Source(label, size, folder, view, tuple(find_problems(view.raw)))


def human_size(size: int) -> str:
    """1,234 B, 12.3 kB, 4.5 MB: decimal units, as the platform shows file sizes."""
    if size < 1000:
        return f"{size:,} B"
    for unit, scale in (("kB", 1e3), ("MB", 1e6), ("GB", 1e9)):
        if size < scale * 1000 or unit == "GB":
            return f"{size / scale:.1f} {unit}"
    raise AssertionError("unreachable")
