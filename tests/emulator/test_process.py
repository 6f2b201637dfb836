"""The emulator in its own process, `serve`, and the stook.testing helpers."""

from __future__ import annotations

import asyncio
import contextlib
import io
import json
import subprocess
import sys
from pathlib import Path

import aiohttp

from stook.emulator import Emulator, EmulatorConfig, EmulatorProcess, serve
from stook.testing import emulated_batch, emulated_report, pytest_plugin

# The plugin's fixtures, made visible to this module (a user lists the plugin instead).
stook_emulator_config = pytest_plugin.stook_emulator_config
stook_emulator = pytest_plugin.stook_emulator
stook_batch_inputs = pytest_plugin.stook_batch_inputs


async def test_emulator_in_a_separate_process_reports_its_urls_and_stats(tmp_path: Path) -> None:
    config = EmulatorConfig(jobs_per_batch=9, default_page_size=4, max_page_size=4)
    with EmulatorProcess(config) as emu:
        assert emu.api_url.endswith("/v1")
        config_file = emu.write_batch_config(tmp_path)
        assert json.loads(config_file.read_text())["batchID"] == str(emu.batch_id)
        headers = {"Authorization": f"Bearer {emu.token}"}
        url = f"{emu.api_url}/projects/{emu.project_id}/batches/{emu.batch_id}/jobs"
        async with aiohttp.ClientSession() as session, session.get(url, headers=headers) as r:
            body = await r.json()
        assert r.status == 200
        assert body["total"] == 9
        stats = await asyncio.to_thread(emu.stats)
        assert stats.endpoints["api:list_jobs"] == 1
        # The same seed gives the same IDs in another process.
        async with Emulator(config) as local:
            assert local.batch_id == emu.batch_id
            assert local.project_id == emu.project_id


async def test_serve_prints_where_and_runs_until_cancelled() -> None:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        task = asyncio.create_task(serve(EmulatorConfig(jobs_per_batch=2)))
        for _ in range(100):
            await asyncio.sleep(0.01)
            if "authToken" in out.getvalue():
                break
        task.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await task
    text = out.getvalue()
    assert "apiURL:    http://127.0.0.1:" in text
    assert "stook-emulator-token" in text


async def test_emulated_batch_writes_the_inputs_folder(tmp_path: Path) -> None:
    inputs = tmp_path / "inputs"
    async with emulated_batch(inputs, jobs_per_batch=3) as emu:
        written = json.loads((inputs / "batch_metrics_config.json").read_text())
        assert written["apiURL"] == emu.api_url
        assert len(emu.dataset.jobs(emu.batch_id)) == 3
    async with emulated_report(inputs, seed=5) as emu:
        written = json.loads((inputs / "report_config.json").read_text())
        assert written["reportID"] == str(emu.report_id)
        assert emu.config.default_page_size == 7  # small test pages by default


async def test_the_pytest_fixtures(stook_emulator: Emulator, stook_batch_inputs: Path) -> None:
    written = json.loads((stook_batch_inputs / "batch_metrics_config.json").read_text())
    assert written["batchID"] == str(stook_emulator.batch_id)
    assert written["authToken"] == stook_emulator.token


def test_the_helpers_import_without_pytest() -> None:
    # A metrics-build author's own test runner need not be pytest: only the plugin needs it.
    code = (
        "import sys; sys.modules['pytest'] = None; sys.modules['pytest_asyncio'] = None\n"
        "from stook.testing import emulated_batch, emulated_report, TEST_DEFAULTS\n"
        "try:\n"
        "    import stook.testing.pytest_plugin\n"
        "except ImportError:\n"
        "    print('plugin needs pytest')\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout == "plugin needs pytest\n"
