"""Write a file so that readers see the old content or the whole new one, never a part."""

from __future__ import annotations

import contextlib
import functools
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

from stook.sdk._errors import OutputWriteError


def _naming_the_path(
    write: Callable[[str | os.PathLike[str], bytes], Path],
) -> Callable[[str | os.PathLike[str], bytes], Path]:
    """Turn an OSError of the write into an OutputWriteError that names the path.

    ENOSPC from a write() or fsync() names no file, so without this a full disk reads
    ``[Errno 28] No space left on device`` with no hint of where.
    """

    @functools.wraps(write)
    def naming(path: str | os.PathLike[str], content: bytes) -> Path:
        try:
            return write(path, content)
        except OutputWriteError:
            raise
        except OSError as exc:
            raise OutputWriteError(
                exc.errno, exc.strerror or str(exc) or type(exc).__name__, os.fspath(path)
            ) from exc

    return naming


@_naming_the_path
def write_atomic(path: str | os.PathLike[str], content: bytes) -> Path:
    """Write `content` to `path` via a temporary file in the same folder and a rename.

    The rename is atomic on POSIX within one file system, which is why the
    temporary file lives beside the target rather than in /tmp. The data is
    fsync'ed before the rename so that a crash cannot leave a renamed but
    empty file behind.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{target.name}.", suffix=".tmp", dir=target.parent)
    try:
        with os.fdopen(fd, "wb") as tmp:
            tmp.write(content)
            tmp.flush()
            os.fsync(tmp.fileno())
        os.chmod(tmp_name, 0o644)
        os.replace(tmp_name, target)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp_name)
        raise
    with contextlib.suppress(OSError):
        dir_fd = os.open(target.parent, os.O_RDONLY)
        try:
            os.fsync(dir_fd)
        finally:
            os.close(dir_fd)
    return target
