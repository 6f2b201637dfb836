"""The packaging: three wheels into a fresh venv give a working `stook` command.

Checks what an editable development install hides: that `stook` is a namespace package
spread over three wheels (none may ship ``stook/__init__.py``), that each ships its
``py.typed``, and that the ``stook`` console script runs batch mode with the platform's
folder layout against an emulated ReSim.

Third-party dependencies come from the development venv through a ``.pth`` file, so no
network is needed beyond what building the wheels takes (hatchling, when it is not
installed in the development venv).
"""

from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

from tests.e2e.support import OUTPUT_NAME, EmulatorThread, by_name, config, read_output
from tests.failures import failure_lines

REPO = Path(__file__).resolve().parents[2]
DISTRIBUTIONS = {"proto": "stook/proto", "sdk": "stook/sdk", "service": "stook/service"}


def _run(argv: list[str], **kwargs: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run(  # type: ignore[call-overload, no-any-return]
        argv, capture_output=True, text=True, timeout=180, check=False, **kwargs
    )


def _build_wheels(dest: Path) -> list[Path]:
    have_hatchling = importlib.util.find_spec("hatchling") is not None
    argv = [sys.executable, "-m", "pip", "wheel", "--no-deps", "--quiet", "-w", str(dest)]
    if have_hatchling:
        argv.append("--no-build-isolation")
    done = _run([*argv, *(str(REPO / d) for d in DISTRIBUTIONS)])
    if done.returncode != 0:
        hint = (
            ""
            if have_hatchling
            else " (hatchling is not in the dev venv, so pip had to fetch it: add "
            "'hatchling' to the dev dependency group to build wheels offline)"
        )
        pytest.fail(f"building the wheels failed{hint}:\n{done.stderr[-3000:]}")
    wheels = sorted(dest.glob("*.whl"))
    assert len(wheels) == 3, wheels
    return wheels


@pytest.mark.slow
def test_wheels_install_into_a_fresh_venv_and_run_batch_mode(tmp_path: Path) -> None:
    wheels = _build_wheels(tmp_path / "wheels")

    # Each wheel holds its own part of the `stook` namespace, typed, and no stook/__init__.py.
    names = {wheel: set(zipfile.ZipFile(wheel).namelist()) for wheel in wheels}
    for wheel, files in names.items():
        assert "stook/__init__.py" not in files, wheel.name
    everything = set().union(*names.values())
    for package in DISTRIBUTIONS.values():
        assert f"{package}/__init__.py" in everything
        assert f"{package}/py.typed" in everything
    # The production wheels hold only what a metrics build runs: no emulator, no test
    # helpers, no benchmarks (those are stook-testing's), and no test module of any kind.
    tooling = sorted(
        name
        for name in everything
        if name.startswith(("stook/emulator/", "stook/testing", "stook/bench/"))
        or "/test_" in name
        or "pytest" in name
    )
    assert tooling == [], tooling

    venv = tmp_path / "venv"
    done = _run([sys.executable, "-m", "venv", "--without-pip", str(venv)])
    assert done.returncode == 0, done.stderr
    python = venv / "bin" / "python"
    site_packages = Path(
        _run(
            [str(python), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"]
        ).stdout.strip()
    )
    # Third-party packages from the development venv; its editable stook installs are
    # .pth files there, which a path added this way does not process.
    (site_packages / "_dev_dependencies.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    done = _run(
        [
            sys.executable,
            "-m",
            "pip",
            "--python",
            str(python),
            "install",
            "--no-deps",
            "--no-index",
            "--quiet",
            *map(str, wheels),
        ]
    )
    assert done.returncode == 0, done.stderr

    clean_env = {k: v for k, v in os.environ.items() if not k.startswith(("STOOK_", "PYTHON"))}
    # The three parts import from the new venv, not from the source tree.
    where = _run(
        [
            str(python),
            "-c",
            "import stook.proto, stook.sdk, stook.service; "
            "print(stook.proto.__file__, stook.sdk.__file__, stook.service.__file__)",
        ],
        cwd=tmp_path,
        env=clean_env,
    )
    assert where.returncode == 0, where.stderr
    for path in where.stdout.split():
        assert Path(path).is_relative_to(site_packages), path

    stook = venv / "bin" / "stook"
    assert stook.exists()
    resim = tmp_path / "resim"
    inputs, outputs = resim / "inputs", resim / "outputs"
    with EmulatorThread(config(jobs_per_batch=40, seed=53)) as emu:
        emu.write_batch_config(inputs)
        done = _run(
            [str(stook), "run", "--inputs", str(inputs), "--outputs", str(outputs)],
            cwd=tmp_path,
            env=clean_env,
        )
        requests = emu.stats.requests["api"]
    assert done.returncode == 0, done.stderr
    assert failure_lines(done.stderr) == []
    assert requests > 40  # the jobs were really fetched, not just the listing
    view = read_output(outputs / OUTPUT_NAME)
    assert view.job_id == emu.batch_id
    metrics = by_name(view)
    assert {"Job statuses", "Pass rate", "Max speed (mean)"} <= set(metrics)
    assert sorted(p.name for p in outputs.iterdir()) == [OUTPUT_NAME]
