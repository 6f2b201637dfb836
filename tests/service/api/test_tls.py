"""TLS: a transport verifies certificates with aiohttp's default context, which reads the
environment's CA paths (SSL_CERT_FILE) when aiohttp is imported; so each case runs in a
fresh interpreter.
The server's certificate (tls/server.pem, for 127.0.0.1) is signed by tls/ca.pem, a test
CA that no system trusts.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

TLS = Path(__file__).parent / "tls"

# Serves "hello" over TLS on 127.0.0.1 and GETs it through an HttpTransport; prints the
# status and body, or the error's type.
SERVE_AND_GET = """
import asyncio, ssl
from aiohttp import web
from yarl import URL
from stook.service.api._transport import HttpTransport

async def hello(request):
    return web.Response(text="hello")

async def main():
    app = web.Application()
    app.router.add_get("/", hello)
    runner = web.AppRunner(app)
    await runner.setup()
    server_tls = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    server_tls.load_cert_chain({cert!r}, {key!r})
    site = web.TCPSite(runner, "127.0.0.1", 0, ssl_context=server_tls)
    await site.start()
    port = runner.addresses[0][1]
    try:
        async with HttpTransport(name="api", concurrency=1, request_timeout=30) as http:
            answer = await http.get(URL(f"https://127.0.0.1:{{port}}/"))
            print(answer.status, answer.body.decode())
    except Exception as error:
        print(type(error).__name__)
    finally:
        await runner.cleanup()

# On the loop `stook run` picks (STOOK_EVENT_LOOP): uvloop brings its own TLS transport.
from stook.service.modes import run_on_event_loop
run_on_event_loop(main())
"""


def _run(script: str, **env: str) -> str:
    clean = {k: v for k, v in os.environ.items() if k not in ("SSL_CERT_FILE", "SSL_CERT_DIR")}
    done = subprocess.run(
        [sys.executable, "-c", script],
        capture_output=True,
        text=True,
        timeout=120,
        env={**clean, **env},
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def _serve_and_get(*, ca: bool, loop: str = "asyncio") -> str:
    script = SERVE_AND_GET.format(cert=str(TLS / "server.pem"), key=str(TLS / "server.key"))
    env = {"STOOK_EVENT_LOOP": loop}
    out = _run(script, **env, **({"SSL_CERT_FILE": str(TLS / "ca.pem")} if ca else {}))
    return out.splitlines()[-1]  # after the transport's debug log lines


@pytest.mark.parametrize("loop", ["asyncio", "uvloop"])
def test_a_transport_trusts_the_ca_paths_of_the_environment(loop: str) -> None:
    assert _serve_and_get(ca=True, loop=loop) == "200 hello"


@pytest.mark.parametrize("loop", ["asyncio", "uvloop"])
def test_a_transport_refuses_a_certificate_no_trusted_ca_signed(loop: str) -> None:
    assert _serve_and_get(ca=False, loop=loop) == "TransportError"
