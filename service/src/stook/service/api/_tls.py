"""aiohttp imported without the TLS contexts it builds at import, and the one stook uses.

aiohttp builds two default TLS contexts when it is imported, a verifying one and one that
verifies nothing, and each loads the system's CA bundle (~150 certificates parsed): ~55 ms,
a seventh of `stook run`'s start-up, before a first request that may not even use TLS.
A transport needs one verifying context at most. So the `stook` command imports aiohttp
through :func:`import_aiohttp_without_tls_defaults`, which points OpenSSL's default CA
paths (``SSL_CERT_FILE``, ``SSL_CERT_DIR``) at nothing for the import alone: the two
contexts hold no CA and cost next to nothing. Every transport then brings its own context,
:func:`transport_tls`, built as aiohttp builds its verifying one (the system's defaults,
ALPN ``http/1.1``), once per process, when the first transport opens. Without that import
(a program using stook as a library) transports keep aiohttp's own default.

That context loads the system's CA certificates at its first TLS connection, not when it
is built: loading them is ~240 M instructions (a fifth of `stook run`'s start-up), which a
run against a plain-HTTP API and storage (the emulator, a local deployment) never needs.
An HTTPS run loads them as before, just before its first handshake.

A request that reached aiohttp's emptied default anyway would fail certificate checks: it
fails closed, never open.
"""

from __future__ import annotations

import os
import ssl
import sys
import threading
from typing import Any, Final, Literal

__all__ = ["import_aiohttp_without_tls_defaults", "transport_tls"]

_CA_PATHS: Final = ("SSL_CERT_FILE", "SSL_CERT_DIR")
# No such file or folder: OpenSSL skips a default CA path it cannot read, without an error.
_NOWHERE: Final = "/nonexistent/stook-no-ca-at-aiohttp-import"

_own_context_needed = False
_context: ssl.SSLContext | None = None


def import_aiohttp_without_tls_defaults() -> None:
    """Import aiohttp without loading CA certificates into its default TLS contexts.

    Call it before anything imports aiohttp (it does nothing once aiohttp is imported).
    stook's transports then use :func:`transport_tls`'s context; code of the same process
    that asks aiohttp for its default context gets one that trusts no certificate.
    """
    if "aiohttp" in sys.modules:
        return
    saved = {name: os.environ.get(name) for name in _CA_PATHS}
    for name in _CA_PATHS:
        os.environ[name] = _NOWHERE
    try:
        import aiohttp  # noqa: F401
    finally:
        for name, value in saved.items():
            if value is None:
                del os.environ[name]
            else:
                os.environ[name] = value
    global _own_context_needed
    _own_context_needed = True


def transport_tls() -> ssl.SSLContext | Literal[True]:
    """What a transport's connector verifies TLS with: aiohttp's default (True), or, when
    aiohttp was imported without it, stook's own verifying context."""
    if not _own_context_needed:
        return True
    global _context
    if _context is None:
        context = _CaOnFirstUseContext()  # the system's CA paths, as aiohttp's
        context.set_alpn_protocols(("http/1.1",))
        _context = context
    return _context


class _CaOnFirstUseContext(ssl.SSLContext):
    """The client context ``ssl.create_default_context()`` makes (the same protocol,
    checks and key log), which loads the system's CA certificates (its default verify
    paths, read from the environment then) at its first TLS connection instead of when it
    is made. Until then it holds no CA: nothing can be verified without that connection.
    """

    def __new__(cls) -> _CaOnFirstUseContext:
        return super().__new__(cls, ssl.PROTOCOL_TLS_CLIENT)

    def __init__(self) -> None:
        super().__init__()
        # What create_default_context sets beyond PROTOCOL_TLS_CLIENT's own defaults.
        self.verify_mode = ssl.CERT_REQUIRED
        self.check_hostname = True
        keylog = os.environ.get("SSLKEYLOGFILE")
        if keylog and not sys.flags.ignore_environment:
            self.keylog_filename = keylog
        self._ca_loaded = False
        self._loading = threading.Lock()

    def load_ca_once(self) -> None:
        """Load the default CA paths, once (two loops' first connections may race)."""
        if self._ca_loaded:
            return
        with self._loading:
            if not self._ca_loaded:
                self.load_default_certs()
                self._ca_loaded = True

    # Every TLS connection starts in one of these two: asyncio's (and so aiohttp's)
    # connections in wrap_bio, blocking sockets in wrap_socket.
    def wrap_bio(self, *args: Any, **kwargs: Any) -> ssl.SSLObject:
        self.load_ca_once()
        return super().wrap_bio(*args, **kwargs)

    def wrap_socket(self, *args: Any, **kwargs: Any) -> ssl.SSLSocket:
        self.load_ca_once()
        return super().wrap_socket(*args, **kwargs)
