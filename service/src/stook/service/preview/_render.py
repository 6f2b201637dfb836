"""render_html and write_preview: inputs in, one page out."""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

from stook.sdk import write_atomic
from stook.service.preview._sources import PreviewInput, load_sources

PREVIEW_NAME = "metrics.html"
"""What `stook run --preview` writes beside metrics.binproto."""


def render_html(inputs: PreviewInput | Iterable[PreviewInput]) -> str:
    """One page for one or more outputs: paths to metrics.binproto files, JobMetrics
    messages or reader views. ReadError (naming the file) for one that is not JobMetrics,
    FileNotFoundError for a path that is not there."""
    from stook.service.preview._page import page

    items: Iterable[PreviewInput]
    if isinstance(inputs, str | os.PathLike) or not isinstance(inputs, Iterable):
        items = [inputs]
    else:
        items = inputs
    return page(load_sources(items))


def write_preview(inputs: PreviewInput | Iterable[PreviewInput], target: Path) -> Path:
    """Render, then write `target` atomically: the whole page or, on any failure, nothing."""
    document = render_html(inputs)
    return write_atomic(target, document.encode("utf-8"))
