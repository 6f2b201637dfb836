"""Preview: metrics.binproto files drawn into one self-contained HTML page.

    from stook.service.preview import render_html
    html = render_html(["outputs/metrics.binproto"])

The page works offline (plotly.js is embedded once, images are embedded from the file's
folder) and shows every metric as the dashboard would, in its order, with the validator's
findings; several files go side by side, one column each. This layer reads files through
stook.sdk's reader only and imports no other layer of stook.service: `stook preview`
(cli) and `stook run --preview` use it.
"""

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


__all__ = ["PREVIEW_NAME", "PreviewInput", "render_html", "write_preview"]
