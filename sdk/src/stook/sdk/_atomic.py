"""Write a file so that readers see the old content or the whole new one, never a part."""

from __future__ import annotations

import contextlib
import functools
import os
import re
import secrets
from collections.abc import Callable
from pathlib import Path

from stook.sdk._errors import OutputWriteError

# Temporary names are tempfile.mkstemp's: `.{name}.` + 8 of these + `.tmp`, so that files
# left by earlier versions, which used mkstemp, are recognised as stale too.
_TEMP_CHARS = "abcdefghijklmnopqrstuvwxyz0123456789_"
_TEMP_RANDOM_LENGTH = 8


def _temp_path(target: Path) -> Path:
    random = "".join(secrets.choice(_TEMP_CHARS) for _ in range(_TEMP_RANDOM_LENGTH))
    return target.parent / f".{target.name}.{random}.tmp"


def _is_temp_name(name: str, target_name: str) -> bool:
    pattern = rf"\.{re.escape(target_name)}\.[{_TEMP_CHARS}]{{{_TEMP_RANDOM_LENGTH}}}\.tmp"
    return re.fullmatch(pattern, name) is not None


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

    Whatever interrupts the write (an error, or an exception that a signal handler
    raises at any point after the temporary file is created) removes the temporary
    file: its name is chosen before it is created, so even an interruption right after
    the creation knows what to remove. Only SIGKILL or a crash can leave one behind;
    `remove_stale_temp_files` clears those.
    """
    target = Path(path)
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp_name = _temp_path(target)
    ours = True
    try:
        try:
            fd = os.open(tmp_name, os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_CLOEXEC, 0o600)
        except FileExistsError:
            ours = False  # another writer's file of the same random name: not ours to remove
            raise
        with os.fdopen(fd, "wb") as tmp:
            tmp.write(content)
            tmp.flush()
            os.fsync(tmp.fileno())
        os.chmod(tmp_name, 0o644)
        os.replace(tmp_name, target)
    except BaseException:
        if ours:
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


def remove_stale_temp_files(path: str | os.PathLike[str]) -> list[Path]:
    """Remove the temporary files that killed `write_atomic(path, ...)` calls left beside
    `path`, and return them.

    Only names of write_atomic's own pattern for this target are touched
    (`.metrics.binproto.` + 8 characters + `.tmp` for metrics.binproto), never other
    files. Best effort: a folder that is missing or cannot be listed has nothing to remove.
    """
    target = Path(path)
    removed: list[Path] = []
    try:
        entries = list(os.scandir(target.parent))
    except OSError:
        return removed
    for entry in entries:
        if _is_temp_name(entry.name, target.name) and entry.is_file(follow_symlinks=False):
            with contextlib.suppress(FileNotFoundError):
                os.unlink(entry.path)
                removed.append(Path(entry.path))
    return removed
