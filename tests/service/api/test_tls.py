"""TLS when aiohttp is imported without its default contexts (stook.service.api._tls).

What matters happens when aiohttp is imported, so each case runs in a fresh interpreter.
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
NOWHERE = "/nonexistent/stook-no-ca-at-aiohttp-import"

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


def _serve_and_get(*, lean: bool, ca: bool, loop: str = "asyncio") -> str:
    first = (
        "from stook.service.api import import_aiohttp_without_tls_defaults\n"
        "import_aiohttp_without_tls_defaults()\n"
        if lean
        else ""
    )
    script = first + SERVE_AND_GET.format(cert=str(TLS / "server.pem"), key=str(TLS / "server.key"))
    env = {"STOOK_EVENT_LOOP": loop}
    out = _run(script, **env, **({"SSL_CERT_FILE": str(TLS / "ca.pem")} if ca else {}))
    return out.splitlines()[-1]  # after the transport's debug log lines


@pytest.mark.parametrize("loop", ["asyncio", "uvloop"])
@pytest.mark.parametrize("lean", [True, False], ids=["lean import", "plain import"])
def test_a_transport_trusts_the_ca_paths_of_the_environment(lean: bool, loop: str) -> None:
    # SSL_CERT_FILE names the test CA: hidden from aiohttp's import by the lean import,
    # it is what the transport's own context reads.
    assert _serve_and_get(lean=lean, ca=True, loop=loop) == "200 hello"


@pytest.mark.parametrize("loop", ["asyncio", "uvloop"])
@pytest.mark.parametrize("lean", [True, False], ids=["lean import", "plain import"])
def test_a_transport_refuses_a_certificate_no_trusted_ca_signed(lean: bool, loop: str) -> None:
    assert _serve_and_get(lean=lean, ca=False, loop=loop) == "TransportError"


def test_the_lean_import_hides_the_ca_paths_from_aiohttp_alone() -> None:
    # Every CA path aiohttp's import loads is nowhere; the environment is as it was after.
    script = (
        "import os, ssl\n"
        "seen = []\n"
        "load = ssl.SSLContext.set_default_verify_paths\n"
        "def recording(self):\n"
        "    seen.append((os.environ.get('SSL_CERT_FILE'), os.environ.get('SSL_CERT_DIR')))\n"
        "    return load(self)\n"
        "ssl.SSLContext.set_default_verify_paths = recording\n"
        "from stook.service.api import import_aiohttp_without_tls_defaults\n"
        "import_aiohttp_without_tls_defaults()\n"
        "print(len(seen), sorted(set(seen)))\n"
        "print(os.environ.get('SSL_CERT_FILE'), os.environ.get('SSL_CERT_DIR'))\n"
    )
    out = _run(script, SSL_CERT_FILE="/etc/mine.pem").splitlines()
    assert out == [f"2 [({NOWHERE!r}, {NOWHERE!r})]", "/etc/mine.pem None"]


def test_without_the_lean_import_transports_keep_aiohttps_default() -> None:
    script = (
        "import aiohttp\nfrom stook.service.api._tls import transport_tls\nprint(transport_tls())\n"
    )
    assert _run(script) == "True\n"


def test_stook_run_imports_aiohttp_without_its_tls_defaults(tmp_path: Path) -> None:
    # `stook run` on an empty inputs folder (test mode: no request) imports what every run
    # imports, aiohttp included, and loads no CA certificate on the way.
    script = (
        "import os, ssl\n"
        "seen = []\n"
        "load = ssl.SSLContext.set_default_verify_paths\n"
        "def recording(self):\n"
        "    seen.append(os.environ.get('SSL_CERT_FILE'))\n"
        "    return load(self)\n"
        "ssl.SSLContext.set_default_verify_paths = recording\n"
        "from stook.service.cli import main\n"
        "try:\n"
        f"    main(['run', '--inputs', {str(tmp_path)!r}, '--outputs', {str(tmp_path)!r}])\n"
        "except SystemExit:\n"
        "    print('aiohttp' in __import__('sys').modules, sorted(set(seen)))\n"
    )
    assert _run(script).splitlines()[-1] == f"True [{NOWHERE!r}]"


# GETs "hello" over plain HTTP, then twice over TLS, from a lean-imported aiohttp; prints how
# many CA certificates the transports' context holds after each.
CA_ON_FIRST_USE = """
from stook.service.api import import_aiohttp_without_tls_defaults
import_aiohttp_without_tls_defaults()
import asyncio, ssl
from aiohttp import web
from yarl import URL
from stook.service.api._tls import transport_tls
from stook.service.api._transport import HttpTransport

def cas():
    return transport_tls().cert_store_stats()["x509_ca"]

async def hello(request):
    return web.Response(text="hello")

async def get(tls):
    app = web.Application()
    app.router.add_get("/", hello)
    runner = web.AppRunner(app)
    await runner.setup()
    server_tls = ssl.create_default_context(ssl.Purpose.CLIENT_AUTH)
    server_tls.load_cert_chain({cert!r}, {key!r})
    site = web.TCPSite(runner, "127.0.0.1", 0, ssl_context=server_tls if tls else None)
    await site.start()
    port = runner.addresses[0][1]
    scheme = "https" if tls else "http"
    try:
        async with HttpTransport(name="api", concurrency=1, request_timeout=30) as http:
            answer = await http.get(URL(f"{{scheme}}://127.0.0.1:{{port}}/"))
            assert (answer.status, answer.body) == (200, b"hello")
    finally:
        await runner.cleanup()

print("built", cas())
asyncio.run(get(tls=False))
print("http", cas())
asyncio.run(get(tls=True))
print("https", cas())
asyncio.run(get(tls=True))
print("again", cas())
"""


def test_the_transports_context_loads_the_ca_paths_at_its_first_tls_connection() -> None:
    # A plain-HTTP request leaves it without a CA (a run against the emulator never loads
    # the system's); the first TLS connection loads the environment's CA paths, once.
    script = CA_ON_FIRST_USE.format(cert=str(TLS / "server.pem"), key=str(TLS / "server.key"))
    out = _run(script, SSL_CERT_FILE=str(TLS / "ca.pem")).splitlines()
    assert [line for line in out if line.split()[0] in ("built", "http", "https", "again")] == [
        "built 0",
        "http 0",
        "https 1",
        "again 1",
    ]
