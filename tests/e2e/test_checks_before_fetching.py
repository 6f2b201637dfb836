"""What can be checked before the first request is checked before it, and what can only fail
at the end (a full disk) fails with one line naming the path.

Real processes where the process is the point: another user id (setpriv), a full file
system (a small tmpfs), a file-size limit, and the import path of the `stook` script.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import resource
import shutil
import stat
import subprocess
import sys
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.emulator import Emulator
from stook.service.cli import run_cli
from tests.e2e.support import (
    BATCH_TOML,
    OUTPUT_NAME,
    EmulatorThread,
    by_name,
    config,
    outputs_left,
    read_output,
    write_batch_inputs,
)
from tests.failures import failure_lines

IMAGE_UID = 10001  # the non-root user of deploy/Dockerfile's optional variant
SETPRIV = shutil.which("setpriv")
UNSHARE = shutil.which("unshare")
CHECKOUT = Path(__file__).resolve().parents[2]  # its .venv and the stook sources
EXAMPLE_TOML = '[test]\nmetrics = "stook.sdk.example:every_metric_type"\n'


# No ./stook.toml and no STOOK_* settings from the environment (tests/e2e/conftest.py).
pytestmark = pytest.mark.usefixtures("isolated")


@pytest.fixture(scope="module")
def emu() -> Iterator[Emulator]:
    with EmulatorThread(config(jobs_per_batch=12, seed=5)) as emulator:
        yield emulator


def stook_command() -> list[str]:
    """The installed console script, as the image's entry point runs it."""
    script = Path(sys.executable).parent / "stook"
    assert script.exists(), f"no installed stook command at {script}"
    return [str(script)]


def clean_env() -> dict[str, str]:
    """No STOOK_* settings and no PYTHONPATH: only what stook itself puts on the path."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_") and k != "PYTHONPATH"}
    env["PYTHONDONTWRITEBYTECODE"] = "1"
    return env


def run_process(
    argv: list[str], *, cwd: Path, **kwargs: object
) -> subprocess.CompletedProcess[str]:
    return subprocess.run(  # type: ignore[call-overload, no-any-return]
        argv,
        cwd=cwd,
        env=clean_env(),
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        **kwargs,
    )


def error_line(stderr: str) -> str:
    lines = failure_lines(stderr)
    assert len(lines) == 1, stderr
    assert "Traceback" not in stderr, stderr
    return lines[0]


def in_process(
    capsys: pytest.CaptureFixture[str], inputs: Path, outputs: Path, toml: str | None = None
) -> tuple[int, str]:
    argv = ["run", "--inputs", str(inputs), "--outputs", str(outputs), "--log-format", "json"]
    if toml is not None:
        path = inputs.parent / "stook.toml"
        path.write_text(toml)
        argv += ["--config", str(path)]
    code = run_cli(argv)
    return code, capsys.readouterr().err


def closed_to_others(path: Path) -> Path | None:
    """The outermost folder above `path` that other users cannot enter, if any."""
    for folder in reversed(path.parents):  # "/" first
        if not folder.stat().st_mode & stat.S_IXOTH:
            return folder
    return None


# Run in a private mount namespace (gone with the process): the checkout is bound aside,
# an open tmpfs covers the closed folder, and the checkout is bound back at its own path
# inside it, so the .venv's absolute paths (script lines, editable installs) still hold.
_REOPEN = '''mount --bind "$1" "$2"
mount -t tmpfs -o mode=755,size=1m stook-open "$3"
mkdir -p "$1"
mount --bind "$2" "$1"
shift 3
exec "$@"'''


def as_image_user(argv: list[str], spare: Path) -> list[str]:
    """`argv` run as the image's user, who must reach the checkout's .venv and sources.

    A clone under a folder others cannot enter (`mktemp -d` makes 0700 ones) is made
    reachable for that process only, never by changing the folder's mode; `spare` is an
    empty folder to hold the checkout meanwhile.
    """
    assert SETPRIV is not None
    drop = [SETPRIV, f"--reuid={IMAGE_UID}", f"--regid={IMAGE_UID}", "--clear-groups"]
    closed = closed_to_others(CHECKOUT)
    if closed is None:
        return [*drop, *argv]
    assert Path(sys.prefix).is_relative_to(CHECKOUT), f"{sys.prefix} is outside {CHECKOUT}"
    if UNSHARE is None or subprocess.run([UNSHARE, "--mount", "true"], check=False).returncode:
        pytest.skip(f"{closed} is closed to other users and no mount namespace can open it")
    reopen = [UNSHARE, "--mount", "--propagation", "private", "sh", "-euc", _REOPEN, "sh"]
    return [*reopen, str(CHECKOUT), str(spare), str(closed), *drop, *argv]


@contextlib.contextmanager
def world_readable_folder() -> Iterator[Path]:
    """A folder another user can reach (pytest's tmp_path is private to root)."""
    base = Path(tempfile.mkdtemp(prefix="stook-other-user-"))
    base.chmod(0o755)
    try:
        yield base
    finally:
        shutil.rmtree(base)


# ---- the outputs folder, before the first request ----


@pytest.mark.skipif(
    os.geteuid() != 0 or SETPRIV is None,
    reason="running as another user needs root and setpriv (util-linux)",
)
@pytest.mark.parametrize("owner", ["root", "image-user"])
def test_the_image_user_against_a_root_owned_outputs_folder(emu: Emulator, owner: str) -> None:
    assert SETPRIV is not None
    with world_readable_folder() as base:
        inputs = base / "inputs"
        write_batch_inputs(inputs, emu).chmod(0o644)
        inputs.chmod(0o755)
        outputs = base / "outputs"
        outputs.mkdir(mode=0o755)  # root's, as the platform may mount it
        if owner == "image-user":
            os.chown(outputs, IMAGE_UID, IMAGE_UID)
        (base / "spare").mkdir()
        before = emu.stats.requests["api"]
        stook_run = [*stook_command(), "run", "--inputs", str(inputs), "--outputs", str(outputs)]
        done = run_process(as_image_user(stook_run, base / "spare"), cwd=base)
        if owner == "image-user":  # the control: the same user and command can write there
            assert done.returncode == 0, done.stderr
            read_output(outputs / OUTPUT_NAME)
            return
        assert done.returncode == 2, done.stderr
        line = error_line(done.stderr)
        assert f"outputs folder {str(outputs)!r} is not writable by user id {IMAGE_UID}" in line
        assert "Permission denied" in line
        assert "deploy/README.md" in line
        assert emu.stats.requests["api"] == before  # refused before any fetching
        assert os.listdir(outputs) == []


def test_an_outputs_folder_that_cannot_be_made_fails_before_fetching(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    write_batch_inputs(tmp_path / "inputs", emu)
    (tmp_path / "a-file").write_text("not a folder")
    outputs = tmp_path / "a-file" / "outputs"
    before = emu.stats.requests["api"]
    code, err = in_process(capsys, tmp_path / "inputs", outputs)
    assert code == 2, err
    line = error_line(err)
    assert f"outputs folder {str(outputs)!r} cannot be created by user id {os.geteuid()}" in line
    assert emu.stats.requests["api"] == before


def test_the_probe_leaves_nothing_behind(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    inputs = tmp_path / "inputs"
    (inputs / "experience").mkdir(parents=True)
    code, err = in_process(capsys, inputs, tmp_path / "new" / "outputs")
    assert code == 0, err
    assert outputs_left(tmp_path / "new" / "outputs") == [OUTPUT_NAME]


# ---- a full disk during the write ----


@contextlib.contextmanager
def full_tmpfs(base: Path) -> Iterator[Path]:
    """A 64 kB tmpfs with an outputs folder in it and every byte taken by a filler file."""
    mount = base / "disk"
    mount.mkdir()
    mounted = subprocess.run(
        ["mount", "-t", "tmpfs", "-o", "size=64k", "tmpfs", str(mount)],
        capture_output=True,
        check=False,
    )
    if mounted.returncode != 0:
        pytest.skip(f"cannot mount a tmpfs here: {mounted.stderr.decode().strip()}")
    try:
        (mount / "outputs").mkdir()
        filler = os.open(mount / "filler", os.O_WRONLY | os.O_CREAT, 0o644)
        try:
            with contextlib.suppress(OSError):
                while True:
                    os.write(filler, b"\0" * 4096)
        finally:
            os.close(filler)
        yield mount / "outputs"
    finally:
        subprocess.run(["umount", str(mount)], check=True)


@pytest.mark.skipif(os.geteuid() != 0, reason="mounting a tmpfs needs root")
def test_a_full_disk_is_one_line_naming_the_path(tmp_path: Path) -> None:
    inputs = tmp_path / "inputs"
    (inputs / "experience").mkdir(parents=True)
    (tmp_path / "stook.toml").write_text(EXAMPLE_TOML)
    with full_tmpfs(tmp_path) as outputs:
        done = run_process(
            [*stook_command(), "run", "--inputs", str(inputs), "--outputs", str(outputs)],
            cwd=tmp_path,
        )
        left = outputs_left(outputs)
    assert done.returncode == 5, done.stderr
    line = error_line(done.stderr)
    assert line == (
        f"stook: error: cannot write {outputs / OUTPUT_NAME}: No space left on device"
    ), line
    assert left == []  # neither the output nor its temporary file


def test_a_file_size_limit_is_one_line_naming_the_path(tmp_path: Path) -> None:
    inputs = tmp_path / "inputs"
    (inputs / "experience").mkdir(parents=True)
    (tmp_path / "stook.toml").write_text(EXAMPLE_TOML)
    outputs = tmp_path / "outputs"

    def limit_file_size() -> None:
        # Python ignores SIGXFSZ, so a write past the limit fails with EFBIG instead.
        resource.setrlimit(resource.RLIMIT_FSIZE, (1024, 1024))

    done = run_process(
        [*stook_command(), "run", "--inputs", str(inputs), "--outputs", str(outputs)],
        cwd=tmp_path,
        preexec_fn=limit_file_size,
    )
    assert done.returncode == 5, done.stderr
    line = error_line(done.stderr)
    assert line == f"stook: error: cannot write {outputs / OUTPUT_NAME}: File too large", line
    assert outputs_left(outputs) == []


# ---- test mode finds the user's module the way the README says ----


USER_MODULE = """\
from stook.sdk import MetricsWriter


def compute(experience_dir, logs_dir, writer: MetricsWriter) -> None:
    writer.scalar("Found beside {where}", 1.0)
"""


def test_the_readme_example_works_as_written(tmp_path: Path) -> None:
    """./stook.toml and my_metrics/ in the working directory, no PYTHONPATH."""
    project = tmp_path / "project"
    (project / "my_metrics").mkdir(parents=True)
    (project / "my_metrics" / "__init__.py").write_text("")
    (project / "my_metrics" / "test.py").write_text(USER_MODULE.format(where="the cwd"))
    (project / "stook.toml").write_text('[test]\nmetrics = "my_metrics.test:compute"\n')
    inputs = tmp_path / "inputs"
    (inputs / "experience").mkdir(parents=True)
    done = run_process(
        [*stook_command(), "run", "--inputs", str(inputs), "--outputs", str(tmp_path / "out")],
        cwd=project,
    )
    assert done.returncode == 0, done.stderr
    assert set(by_name(read_output(tmp_path / "out" / OUTPUT_NAME))) == {"Found beside the cwd"}


def test_a_module_beside_the_config_file_is_found(tmp_path: Path) -> None:
    (tmp_path / "conf").mkdir()
    (tmp_path / "conf" / "stook_cfg_metrics.py").write_text(USER_MODULE.format(where="config"))
    (tmp_path / "conf" / "stook.toml").write_text('[test]\nmetrics = "stook_cfg_metrics:compute"\n')
    (tmp_path / "elsewhere").mkdir()
    inputs = tmp_path / "inputs"
    (inputs / "logs").mkdir(parents=True)
    done = run_process(
        [
            *stook_command(),
            "run",
            "--config",
            "../conf/stook.toml",
            "--inputs",
            str(inputs),
            "--outputs",
            str(tmp_path / "out"),
        ],
        cwd=tmp_path / "elsewhere",
    )
    assert done.returncode == 0, done.stderr
    assert set(by_name(read_output(tmp_path / "out" / OUTPUT_NAME))) == {"Found beside config"}


def test_an_import_failure_says_what_was_searched(tmp_path: Path) -> None:
    (tmp_path / "conf").mkdir()
    (tmp_path / "conf" / "stook.toml").write_text('[test]\nmetrics = "no_such_pkg.test:compute"\n')
    inputs = tmp_path / "inputs"
    (inputs / "experience").mkdir(parents=True)
    done = run_process(
        [
            *stook_command(),
            "run",
            "--config",
            str(tmp_path / "conf" / "stook.toml"),
            "--inputs",
            str(inputs),
            "--outputs",
            str(tmp_path / "out"),
        ],
        cwd=tmp_path,
    )
    assert done.returncode == 2, done.stderr
    line = error_line(done.stderr)
    assert "'no_such_pkg.test:compute' cannot be imported (No module named 'no_such_pkg')" in line
    assert f"searched the config file's folder {str(tmp_path / 'conf')!r}" in line
    assert f"the working directory {str(tmp_path)!r}" in line
    assert "then the Python path" in line
    assert outputs_left(tmp_path / "out") == []


# ---- a misspelt platform config is not test mode ----


@pytest.mark.parametrize(
    ("name", "meant"),
    [
        ("batch_metric_config.json", "batch_metrics_config.json"),
        ("Batch_Metrics_Config.json", "batch_metrics_config.json"),
        ("report-config.json", "report_config.json"),
    ],
)
def test_a_misspelt_config_is_named_not_run_as_test_mode(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, name: str, meant: str
) -> None:
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    (inputs / name).write_text(json.dumps({"batchID": "x"}))
    code, err = in_process(capsys, inputs, tmp_path / "outputs")
    assert code == 2, err
    line = error_line(err)
    assert f"has {name!r} but no batch_metrics_config.json" in line
    assert line.endswith(f"did you mean {meant}?")
    assert outputs_left(tmp_path / "outputs") == []


def test_an_unrelated_file_leaves_test_mode_alone(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    (inputs / "notes.txt").write_text("hello")
    code, err = in_process(capsys, inputs, tmp_path / "outputs")
    assert code == 0, err


# ---- stook.toml checked before fetching, its caps applied ----


def test_an_aggregation_typo_is_named_before_fetching(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    write_batch_inputs(tmp_path / "inputs", emu)
    before = emu.stats.requests["api"]
    toml = BATCH_TOML.replace("buckets = ", "bins = ")
    code, err = in_process(capsys, tmp_path / "inputs", tmp_path / "outputs", toml)
    assert code == 2, err
    line = error_line(err)
    assert "[[batch.histogram]] #1: unknown key 'bins' (known: buckets, data, lower," in line
    assert "__init__" not in line
    assert emu.stats.requests["api"] == before


def test_the_body_cap_setting_reaches_storage(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    write_batch_inputs(tmp_path / "inputs", emu)
    toml = "[fetch]\nmax_body_mb = 0.0001\n" + BATCH_TOML  # about 100 bytes
    code, err = in_process(capsys, tmp_path / "inputs", tmp_path / "outputs", toml)
    assert code == 3, err
    assert "jobs missing, allowed share 0" in error_line(err)
    # Each over-cap job is named in its own warning, the run's one error line sums them up.
    warnings = [line for line in err.splitlines() if "job unavailable" in line]
    assert warnings, err
    assert all("larger than 104 bytes (the [fetch] max_body_mb cap)" in w for w in warnings)
    assert all("X-Amz-Signature=***" in w for w in warnings)
    assert set(re.findall(r"X-Amz-Signature=([^&\s]+)", err)) <= {"***"}
    assert outputs_left(tmp_path / "outputs") == []
