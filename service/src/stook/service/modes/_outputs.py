"""The outputs folder, checked before the first request.

A run that cannot write its output should say so at once, not after an hour of fetching.
The check is a real write: permission bits, ownership, ACLs, read-only mounts and
container user mappings all have their say, which reading the mode bits would not.
"""

from __future__ import annotations

import contextlib
import os
import tempfile
from pathlib import Path

from stook.service.modes._errors import OutputsError

# Not the output's own temporary-file prefix, so a clean-up of those never meets a probe.
_PROBE_PREFIX = ".stook-write-probe-"


def check_outputs_folder(folder: Path) -> None:
    """Create `folder` if need be, then create and remove a file in it; else OutputsError."""
    who = f"user id {os.geteuid()}"
    shown = str(folder)
    try:
        folder.mkdir(parents=True, exist_ok=True)
    except FileExistsError:
        raise OutputsError(f"outputs folder {shown!r} exists but is not a folder") from None
    except OSError as exc:
        raise OutputsError(
            f"outputs folder {shown!r} cannot be created by {who} ({_reason(exc)}): "
            f"create it writable for {who}, or run as a user who may (see deploy/README.md)"
        ) from None
    try:
        fd, probe = tempfile.mkstemp(prefix=_PROBE_PREFIX, dir=folder)
    except OSError as exc:
        raise OutputsError(
            f"outputs folder {shown!r} is not writable by {who} ({_reason(exc)}): "
            f"give {who} write access to it, or run as a user who has it "
            "(see deploy/README.md)"
        ) from None
    os.close(fd)
    with contextlib.suppress(FileNotFoundError):
        os.unlink(probe)


def _reason(exc: OSError) -> str:
    return exc.strerror or type(exc).__name__
