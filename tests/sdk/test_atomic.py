"""write_atomic: the whole new content or the old file, never a part, and no litter."""

from __future__ import annotations

import os
import stat
import uuid
from pathlib import Path

import pytest

from stook.sdk import InvalidMetricsError, MetricsWriter, OutputWriteError, data, write_atomic

JOB = uuid.UUID("0b7a4c1e-5d2f-4e8a-9c3b-6f1d2e3a4b5c")


def _mode(path: Path) -> int:
    return stat.S_IMODE(path.stat().st_mode)


def test_writes_the_whole_content_and_returns_the_path(tmp_path: Path) -> None:
    content = bytes(range(256)) * 40_000  # 10 MB, every byte value
    target = tmp_path / "metrics.binproto"
    result = write_atomic(str(target), content)
    assert result == target
    assert isinstance(result, Path)
    assert target.read_bytes() == content
    assert os.listdir(tmp_path) == ["metrics.binproto"]


def test_writes_empty_content(tmp_path: Path) -> None:
    target = tmp_path / "empty"
    write_atomic(target, b"")
    assert target.read_bytes() == b""


def test_replaces_an_existing_file(tmp_path: Path) -> None:
    target = tmp_path / "metrics.binproto"
    target.write_bytes(b"old content that is longer than the new")
    write_atomic(target, b"new")
    assert target.read_bytes() == b"new"
    assert os.listdir(tmp_path) == ["metrics.binproto"]


def test_creates_missing_folders(tmp_path: Path) -> None:
    target = tmp_path / "a" / "b" / "c" / "metrics.binproto"
    write_atomic(target, b"x")
    assert target.read_bytes() == b"x"


def test_permissions_are_0644_whatever_the_umask(tmp_path: Path) -> None:
    old = os.umask(0o077)
    try:
        target = write_atomic(tmp_path / "f", b"x")
    finally:
        os.umask(old)
    # mkstemp creates 0600; the file must still be readable by others.
    assert _mode(target) == 0o644


def test_permissions_of_a_replaced_file_become_0644(tmp_path: Path) -> None:
    target = tmp_path / "f"
    target.write_bytes(b"old")
    target.chmod(0o600)
    write_atomic(target, b"new")
    assert _mode(target) == 0o644


class DiskFireError(OSError):
    pass


def _raise(*_args: object, **_kwargs: object) -> None:
    raise DiskFireError("disk on fire")


@pytest.mark.parametrize("step", ["fsync", "replace", "chmod"])
def test_a_failure_keeps_the_old_file_and_removes_the_temporary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, step: str
) -> None:
    target = tmp_path / "metrics.binproto"
    target.write_bytes(b"previous")
    monkeypatch.setattr(os, step, _raise)
    with pytest.raises(OutputWriteError, match=f"cannot write {target}: disk on fire"):
        write_atomic(target, b"next")
    monkeypatch.undo()
    assert target.read_bytes() == b"previous"
    assert os.listdir(tmp_path) == ["metrics.binproto"]


@pytest.mark.parametrize("step", ["fsync", "replace"])
def test_a_failure_without_an_old_file_leaves_no_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, step: str
) -> None:
    monkeypatch.setattr(os, step, _raise)
    with pytest.raises(OutputWriteError) as caught:
        write_atomic(tmp_path / "metrics.binproto", b"next")
    assert isinstance(caught.value.__cause__, DiskFireError)
    monkeypatch.undo()
    assert os.listdir(tmp_path) == []


def test_a_failure_while_writing_the_content_keeps_the_old_file(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    target = tmp_path / "metrics.binproto"
    target.write_bytes(b"previous")
    real_fdopen = os.fdopen

    class FailingFile:
        def __init__(self, fd: int) -> None:
            self._file = real_fdopen(fd, "wb")

        def __enter__(self) -> FailingFile:
            return self

        def __exit__(self, *exc: object) -> None:
            self._file.close()

        def write(self, content: bytes) -> int:
            self._file.write(content[: len(content) // 2])  # half of it reaches the disk
            raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fdopen", lambda fd, _mode: FailingFile(fd))
    with pytest.raises(OutputWriteError, match=f"cannot write {target}: No space left"):
        write_atomic(target, b"next content")
    monkeypatch.undo()
    assert target.read_bytes() == b"previous"
    assert os.listdir(tmp_path) == ["metrics.binproto"]


def test_an_interrupt_also_removes_the_temporary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    def interrupt(_fd: int) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "fsync", interrupt)
    with pytest.raises(KeyboardInterrupt):
        write_atomic(tmp_path / "f", b"x")
    monkeypatch.undo()
    assert os.listdir(tmp_path) == []


def test_a_failing_folder_fsync_after_the_rename_is_ignored(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    real_open = os.open

    def open_file_only(path: object, flags: int, *args: object) -> int:
        if Path(str(path)) == tmp_path:
            raise PermissionError("no folder handle here")
        return real_open(path, flags, *args)  # type: ignore[arg-type]

    monkeypatch.setattr(os, "open", open_file_only)
    target = write_atomic(tmp_path / "f", b"done")
    monkeypatch.undo()
    assert target.read_bytes() == b"done"


def test_the_target_being_a_folder_fails_cleanly(tmp_path: Path) -> None:
    (tmp_path / "metrics.binproto").mkdir()
    with pytest.raises(OSError, match=r"(?i)directory"):
        write_atomic(tmp_path / "metrics.binproto", b"x")
    assert os.listdir(tmp_path) == ["metrics.binproto"]
    assert (tmp_path / "metrics.binproto").is_dir()


# ---------------------------------------------------------------- MetricsWriter.write


def test_writer_write_puts_the_serialized_output_in_place(tmp_path: Path) -> None:
    w = MetricsWriter(JOB, deterministic=True)
    w.scalar("s", 1.0)
    w.histogram("h", data.doubles("v", [1.0, 2.0]), buckets=2, lower=0, upper=4)
    target = w.write(tmp_path / "out" / "metrics.binproto")
    assert target == tmp_path / "out" / "metrics.binproto"
    assert target.read_bytes() == w.serialize()
    assert _mode(target) == 0o644
    assert os.listdir(target.parent) == ["metrics.binproto"]


def test_writer_write_refuses_an_invalid_output_and_writes_nothing(tmp_path: Path) -> None:
    w = MetricsWriter(JOB)
    handle = w.scalar("broken", 1.0)
    handle.proto.status = 0  # type: ignore[assignment]
    target = tmp_path / "outputs" / "metrics.binproto"
    with pytest.raises(InvalidMetricsError, match=r"metric 'broken'.*status is unset") as info:
        w.write(target)
    assert [p.where.startswith("metric 'broken'") for p in info.value.problems] == [True]
    assert not target.exists()
    assert not (tmp_path / "outputs").exists() or os.listdir(tmp_path / "outputs") == []


def test_writer_write_keeps_a_previous_file_when_the_output_is_invalid(tmp_path: Path) -> None:
    target = tmp_path / "metrics.binproto"
    target.write_bytes(b"previous")
    w = MetricsWriter(JOB)
    w.text("t", "x").proto.metric_values.text_metric_values.text = ""
    with pytest.raises(InvalidMetricsError, match="text"):
        w.write(target)
    assert target.read_bytes() == b"previous"
    assert os.listdir(tmp_path) == ["metrics.binproto"]


def test_writer_write_without_validation_writes_even_an_invalid_output(tmp_path: Path) -> None:
    w = MetricsWriter(JOB)
    w.scalar("broken", 1.0).proto.status = 0  # type: ignore[assignment]
    target = w.write(tmp_path / "metrics.binproto", validate=False)
    assert target.read_bytes() == w.serialize()
