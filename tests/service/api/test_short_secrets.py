"""Secrets shorter than 8 characters are masked too, without garbling every message."""

from __future__ import annotations

import io
import json
import uuid

import pytest
import structlog

from stook.service.api import RetryPolicy, _redact
from stook.service.api._client import ApiClient
from stook.service.api._errors import AuthError
from stook.service.api._redact import MASK, redact_text, redact_url, register_secret
from stook.service.cli._run import explain
from stook.service.modes._logging import configure_logging
from tests.service.scripted_server import ScriptedServer, answer

PROJECT = uuid.UUID(int=1)
BATCH = uuid.UUID(int=2)


@pytest.fixture(autouse=True)
def _own_secrets(monkeypatch: pytest.MonkeyPatch) -> None:
    """Short secrets registered here must not mask words in the other tests' messages."""
    monkeypatch.setattr(_redact, "_secrets", {})


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("invalid token ab", f"invalid token {MASK}"),
        ("ab was refused", f"{MASK} was refused"),
        ('{"token": "ab"}', f'{{"token": "{MASK}"}}'),
        ("token=ab;", f"token={MASK};"),
        ("path /ab/x", f"path /{MASK}/x"),
        ("ab-ab ab", f"{MASK}-{MASK} {MASK}"),
        # Inside a longer word it is not the token: "about", "tabs", "lab", "ab12", "AB".
        ("about tabs in the lab", "about tabs in the lab"),
        ("ab12 xab AB", "ab12 xab AB"),
    ],
)
def test_a_two_letter_token_is_masked_where_it_stands_alone(text: str, expected: str) -> None:
    register_secret("ab")
    assert redact_text(text) == expected


def test_every_length_is_masked() -> None:
    for secret in ("x", "s3", "k9!", "zq7-Lm", "Abc1234"):
        register_secret(secret)
        assert redact_text(f"echoed: {secret}.") == f"echoed: {MASK}."


def test_a_secret_of_eight_or_more_is_masked_even_inside_a_word() -> None:
    register_secret("k3y5-Z9q")
    assert redact_text("prefixk3y5-Z9qsuffix") == f"prefix{MASK}suffix"


def test_a_short_secret_in_a_url_path_is_masked() -> None:
    register_secret("t0k")
    assert (
        redact_url("https://api.example.com/v1/t0k/jobs")
        == f"https://api.example.com/v1/{MASK}/jobs"
    )
    assert redact_url("https://api.example.com/v1/t0ken/jobs") == (
        "https://api.example.com/v1/t0ken/jobs"
    )


def test_registering_nothing_masks_nothing() -> None:
    register_secret("")
    assert redact_text("nothing to hide") == "nothing to hide"


async def test_a_short_token_echoed_by_the_server_stays_out_of_errors_and_logs(
    server: ScriptedServer, fast_policy: RetryPolicy
) -> None:
    token = "Zk4"
    stream = io.StringIO()
    configure_logging(json=True, level="debug", stream=stream)
    path = f"/v1/projects/{PROJECT}/batches/{BATCH}"
    server.script(path, answer(401, f'{{"error": "token {token} is not valid"}}'.encode()))
    async with ApiClient(server.base_url, token, retry=fast_policy) as api:
        with pytest.raises(AuthError) as caught:
            await api.get_batch(PROJECT, BATCH)
    line = explain(caught.value)
    structlog.get_logger("test").error("stook failed", error=line, token=token)
    assert server.hits(path)[0].headers["Authorization"] == f"Bearer {token}"
    assert token not in line
    assert f"token {MASK} is not valid" in line
    for record in map(json.loads, stream.getvalue().splitlines()):
        assert token not in json.dumps(record)
