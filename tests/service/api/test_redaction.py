"""Neither the token nor a presigned-URL signature reaches a message, a log line or a repr."""

from __future__ import annotations

import io
import json
import uuid

import pytest
import structlog
from structlog.testing import capture_logs
from yarl import URL

from stook.service.api import RetryPolicy
from stook.service.api._client import ApiClient
from stook.service.api._errors import (
    ApiStatusError,
    AuthError,
    RetriesExhaustedError,
    StorageError,
    TransportError,
    body_excerpt,
)
from stook.service.api._redact import redact_text, redact_url, register_secret
from stook.service.modes._logging import configure_logging, redact_event
from tests.service.conftest import RecordingSleep
from tests.service.scripted_server import ScriptedServer, answer, answer_json

TOKEN = "tok-" + "Zm9vYmFy" * 5
SIGNATURE = "0123abcd" * 8
PROJECT = uuid.UUID(int=1)
BATCH = uuid.UUID(int=2)
BATCH_PATH = f"/v1/projects/{PROJECT}/batches/{BATCH}"


@pytest.fixture(autouse=True)
def _token_registered() -> None:
    register_secret(TOKEN)


# -- helpers -----------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("url", "expected"),
    [
        (
            f"https://bucket.s3.amazonaws.com/a/b.binproto?X-Amz-Signature={SIGNATURE}&X-Amz-Expires=900",
            "https://bucket.s3.amazonaws.com/a/b.binproto?X-Amz-Signature=***&X-Amz-Expires=***",
        ),
        (
            "https://api.resim.ai/v1/projects/p/batches?pageSize=100&pageToken=abc&search=x",
            "https://api.resim.ai/v1/projects/p/batches?pageSize=100&pageToken=abc&search=***",
        ),
        ("https://user:pw@host:8443/path#frag", "https://host:8443/path"),
        ("http://127.0.0.1:5000/obj", "http://127.0.0.1:5000/obj"),
        ("/relative/path?sig=1", "/relative/path"),
    ],
)
def test_redact_url(url: str, expected: str) -> None:
    assert redact_url(url) == expected
    assert redact_url(URL(url, encoded=True)) == expected


def test_redact_text_masks_urls_bearer_tokens_and_registered_secrets() -> None:
    text = (
        f"GET https://s.example.com/o?sig={SIGNATURE} with Authorization: Bearer abc.def-ghi "
        f"and the raw token {TOKEN}"
    )
    redacted = redact_text(text)
    assert SIGNATURE not in redacted
    assert TOKEN not in redacted
    assert "abc.def-ghi" not in redacted
    assert redacted == (
        "GET https://s.example.com/o?sig=*** with Authorization: Bearer *** and the raw token ***"
    )


def test_body_excerpt_is_one_short_redacted_line() -> None:
    body = (f"line one\n  token {TOKEN}\n" + "x" * 1000).encode()
    excerpt = body_excerpt(body)
    assert "\n" not in excerpt
    assert TOKEN not in excerpt
    assert len(excerpt) <= 200


def test_error_messages_and_reprs_are_redacted() -> None:
    url = f"https://s.example.com/o?X-Amz-Signature={SIGNATURE}"
    errors: list[Exception] = [
        ApiStatusError(status=500, method="GET", url=url, body=f"bad {TOKEN}".encode()),
        AuthError(status=401, method="GET", url=url, body=f"Bearer {TOKEN}".encode()),
        StorageError(f"failed {url}", url=url),
        TransportError(method="GET", url=url, reason=f"reset while fetching {url}"),
        RetriesExhaustedError(method="GET", url=url, attempts=6, last_reason=f"see {url}"),
    ]
    for error in errors:
        for text in (str(error), repr(error)):
            assert SIGNATURE not in text
            assert TOKEN not in text


# -- the log processor -------------------------------------------------------------------


def test_redact_event_walks_nested_values() -> None:
    event = {
        "event": f"fetching https://s.example.com/o?sig={SIGNATURE}",
        "headers": {"Authorization": f"Bearer {TOKEN}"},
        "urls": [URL(f"https://s.example.com/o?sig={SIGNATURE}")],
        "error": ValueError(f"boom {TOKEN}"),
        "count": 3,
        "id": uuid.UUID(int=5),
    }
    redacted = redact_event(None, "info", event)
    rendered = json.dumps(redacted)
    assert SIGNATURE not in rendered
    assert TOKEN not in rendered
    assert redacted["count"] == 3
    assert redacted["id"] == str(uuid.UUID(int=5))
    assert redacted["error"] == "ValueError: boom ***"


def test_rendered_json_lines_never_contain_secrets() -> None:
    stream = io.StringIO()
    configure_logging(json=True, level="debug", stream=stream)
    log = structlog.get_logger("test")
    log.info("careless", url=f"https://s.example.com/o?X-Amz-Signature={SIGNATURE}", token=TOKEN)
    try:
        raise RuntimeError(f"failed with Bearer {TOKEN}")
    except RuntimeError:
        log.exception("with traceback")
    lines = stream.getvalue().splitlines()
    assert len(lines) == 2
    records = [json.loads(line) for line in lines]
    assert records[0]["event"] == "careless"
    assert records[0]["url"] == "https://s.example.com/o?X-Amz-Signature=***"
    assert "RuntimeError" in records[1]["exception"]
    assert SIGNATURE not in stream.getvalue()
    assert TOKEN not in stream.getvalue()


def test_console_renderer_is_used_for_terminals_and_is_redacted() -> None:
    stream = io.StringIO()
    configure_logging(json=False, stream=stream)
    structlog.get_logger("test").info("hello", token=TOKEN)
    assert "hello" in stream.getvalue()
    assert TOKEN not in stream.getvalue()
    with pytest.raises(json.JSONDecodeError):
        json.loads(stream.getvalue())


def test_non_tty_stream_gets_json_by_default() -> None:
    stream = io.StringIO()
    configure_logging(stream=stream)
    structlog.get_logger("test").info("hello")
    assert json.loads(stream.getvalue())["event"] == "hello"


def test_level_filters_and_unknown_level_is_rejected() -> None:
    stream = io.StringIO()
    configure_logging(json=True, level="warning", stream=stream)
    structlog.get_logger("test").info("hidden")
    assert stream.getvalue() == ""
    with pytest.raises(ValueError, match="unknown log level"):
        configure_logging(level="chatty")


# -- end to end: what the client itself logs ---------------------------------------------


async def test_client_logs_carry_no_secrets(server: ScriptedServer, sleep: RecordingSleep) -> None:
    policy = RetryPolicy(initial_backoff=0, sleep=sleep, max_attempts=3)
    server.script(BATCH_PATH, answer(503), answer_json({"batchID": str(BATCH)}))
    server.script("/obj", answer(500, f"<Error><Sig>{SIGNATURE}</Sig></Error>".encode()))
    presigned = server.url("/obj") + f"?X-Amz-Signature={SIGNATURE}"

    with capture_logs() as captured:
        async with ApiClient(server.base_url, TOKEN, retry=policy) as api:
            await api.get_batch(PROJECT, BATCH)
            with pytest.raises(RetriesExhaustedError) as caught:
                await api.storage.fetch_bytes(presigned)

    retries = [entry for entry in captured if entry["event"] == "retrying request"]
    assert [entry["reason"] for entry in retries] == ["HTTP 503", "HTTP 500", "HTTP 500"]
    assert retries[0]["url"] == server.url(BATCH_PATH)
    assert retries[1]["url"] == server.url("/obj") + "?X-Amz-Signature=***"
    assert retries[0]["log_level"] == "debug"
    everything = repr(captured) + str(caught.value)
    assert TOKEN not in everything
    assert SIGNATURE not in everything


async def test_client_logs_rendered_as_json_carry_no_secrets(
    server: ScriptedServer, sleep: RecordingSleep
) -> None:
    stream = io.StringIO()
    configure_logging(json=True, level="debug", stream=stream)
    policy = RetryPolicy(initial_backoff=0, sleep=sleep)
    server.script("/obj", answer(503), answer(200, b"ok"))
    async with ApiClient(server.base_url, TOKEN, retry=policy) as api:
        assert await api.storage.fetch_bytes(server.url("/obj") + f"?sig={SIGNATURE}") == b"ok"
    lines = [json.loads(line) for line in stream.getvalue().splitlines()]
    assert {line["event"] for line in lines} >= {"retrying request", "http response"}
    assert SIGNATURE not in stream.getvalue()
    assert TOKEN not in stream.getvalue()


def test_capture_logs_with_the_redaction_processor() -> None:
    structlog.reset_defaults()
    with capture_logs(processors=[redact_event]) as captured:
        structlog.get_logger("test").info("oops", header=f"Bearer {TOKEN}")
    assert captured[0]["header"] == "Bearer ***"


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        # Prose punctuation after a URL is not part of it, and must not break its parsing.
        ("see (http://127.0.0.1:4000)", "see (http://127.0.0.1:4000/)"),
        ("at http://h/x?sig=abc, then", "at http://h/x?sig=***, then"),
        ("[http://h/x?sig=abc]. Done", "[http://h/x?sig=***]. Done"),
        # A port that is no number: the URL is hidden, the message survives.
        ("GET http://h:12ab/x failed", "GET <unparseable URL> failed"),
    ],
)
def test_redact_text_survives_urls_inside_prose(text: str, expected: str) -> None:
    assert redact_text(text) == expected
