"""`stook preview FILE... [-o OUT.html] [--open]`."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path
from typing import TextIO

from stook.service.cli._usage import UsageError
from stook.service.preview import write_preview

DEFAULT_SEVERAL = Path("preview.html")


def default_target(files: Sequence[Path]) -> Path:
    """One file: beside it, named like it (metrics.binproto -> metrics.html). Several:
    preview.html in the working folder."""
    if len(files) == 1:
        return files[0].with_suffix(".html")
    return DEFAULT_SEVERAL


def preview_files(
    files: Sequence[Path],
    output: Path | None = None,
    *,
    open_browser: bool = False,
    out: TextIO | None = None,
) -> int:
    for file in files:
        # Checked before reading any: a typo in the third name fails at once, exit 2.
        if not file.exists():
            raise UsageError(f"{str(file)!r}: no such file")
        if not file.is_file():
            raise UsageError(f"{str(file)!r} is not a file")
    target = output or default_target(files)
    if target.suffix.lower() == ".binproto" or target.resolve() in {f.resolve() for f in files}:
        raise UsageError(f"{str(target)!r}: the preview would overwrite an input")
    written = write_preview(files, target)
    print(written, file=out or sys.stdout)
    if open_browser:
        import webbrowser

        webbrowser.open(written.resolve().as_uri())
    return 0
