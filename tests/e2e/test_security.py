"""Credentials stay where they belong: the token only in API requests, signatures only in
the storage requests they sign; neither in logs, output nor error messages."""

from __future__ import annotations

import logging
import os
import re
import uuid
from pathlib import Path
from urllib.parse import parse_qs, urlsplit

import pytest

from stook.service.cli import run_cli
from tests.e2e.support import BATCH_TOML, OUTPUT_NAME, EmulatorThread, config, read_output

SIGNATURE_IN_TEXT = re.compile(r"X-Amz-Signature=([^&\s'\"\\]+)")


@pytest.mark.parametrize("allowed", [None, "0.2"], ids=["all-jobs", "broken-job-allowed"])
def test_no_credential_reaches_storage_logs_or_outputs(
    capsys: pytest.CaptureFixture[str],
    caplog: pytest.LogCaptureFixture,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    allowed: str | None,
) -> None:
    monkeypatch.chdir(tmp_path)
    for name in list(os.environ):
        if name.startswith("STOOK_"):
            monkeypatch.delenv(name)
    caplog.set_level(logging.DEBUG)
    token = f"e2e-secret-{uuid.uuid4().hex}"
    emulator_config = config(
        jobs_per_batch=50,
        seed=41,
        token=token,
        fault_5xx=0.10,
        fault_429=0.03,
        fault_reset=0.02,
        fault_truncate=0.02,
        retry_after_max_s=0,
        broken_jobs=(5,) if allowed else (),
    )
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    (tmp_path / "stook.toml").write_text("[fetch]\nretry_for = 3\n" + BATCH_TOML)
    argv = ["run", "--inputs", str(inputs), "--outputs", str(outputs)]
    argv += ["--config", str(tmp_path / "stook.toml"), "--log-level", "debug"]
    argv += ["--log-format", "json"]
    if allowed:
        argv += ["--allow-missing-jobs", allowed]

    with EmulatorThread(emulator_config) as emu:
        state = emu._state
        signatures: set[str] = set()
        first_signed: set[str] = set()

        def presign(path: str) -> str:
            # The first URL of each object is already expired, so that the client meets
            # storage refusals (403) whose handling might print the URL.
            issued = state.now()
            if path not in first_signed:
                first_signed.add(path)
                issued -= 2 * emu.config.url_lifetime_s
            url = state.signer.sign(state.storage_url, path, issued)
            signatures.update(parse_qs(urlsplit(url).query)["X-Amz-Signature"])
            return url

        monkeypatch.setattr(state, "presign", presign)
        emu.write_batch_config(inputs)
        code = run_cli(argv)
        stats = emu.stats

    out, err = capsys.readouterr()
    assert code == 0, err
    read_output(outputs / OUTPUT_NAME)

    # The run met every kind of trouble it is meant to survive.
    assert stats.fault_count(origin="api") > 0
    assert stats.fault_count(origin="storage") > 0
    assert stats.expired_urls > 0
    assert stats.requests["storage"] > 0
    if allowed:
        assert stats.broken_job_answers > 0

    # Storage never saw the token.
    assert stats.storage_authorization == []
    assert stats.leaked_tokens == 0

    # Every log line was emitted (debug, JSON), and none holds a credential.
    log_text = out + err + caplog.text
    assert '"level": "debug"' in err
    assert "X-Amz-Signature=" in err  # URLs are logged, with their signature masked
    assert token not in log_text
    assert len(signatures) > 50
    leaked = [s for s in signatures if s in log_text]
    assert leaked == []
    assert set(SIGNATURE_IN_TEXT.findall(log_text)) <= {"***"}

    # Nor does any file written to the outputs folder.
    for path in outputs.rglob("*"):
        if path.is_file():
            content = path.read_bytes()
            assert token.encode() not in content, path
            assert not any(s.encode() in content for s in signatures), path
