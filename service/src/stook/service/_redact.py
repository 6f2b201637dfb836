"""Scrubbing of credentials from anything that may end up in a message or a log line.

Two kinds of secret reach the service: the API bearer token (from the platform's config
file) and the signatures in presigned object-storage URLs. The token is registered once
and replaced wherever it appears; URLs lose their query string values, which is where every
presigned-URL scheme (S3 ``X-Amz-Signature``, GCS ``X-Goog-Signature``, Azure ``sig``)
carries the signature and credentials.
"""

from __future__ import annotations

import re
from typing import Final

from yarl import URL

MASK: Final = "***"

# Query parameters that carry no credential and help when reading a log: which page failed.
_SAFE_QUERY_PARAMS: Final = frozenset({"pageSize", "pageToken"})

# Shorter strings would mask innocent words; real tokens are far longer.
_MIN_SECRET_LENGTH: Final = 8

_secrets: set[str] = set()

_URL_IN_TEXT: Final = re.compile(r"""https?://[^\s'"<>`]+""", re.IGNORECASE)
# A short lower-case word after "bearer" ("invalid bearer token") is prose, not a secret;
# registered secrets are masked whatever their shape (see _mask_secrets).
_BEARER_IN_TEXT: Final = re.compile(
    r"(Bearer\s+)(?!(?-i:[a-z]{1,10})(?![A-Za-z0-9._~+/=-]))[A-Za-z0-9._~+/=-]+",
    re.IGNORECASE,
)


def register_secret(secret: str) -> None:
    """Mask ``secret`` wherever :func:`redact_text` (and so every log line) meets it."""
    if len(secret) >= _MIN_SECRET_LENGTH:
        _secrets.add(secret)


def redact_url(url: str | URL) -> str:
    """The URL with scheme, host, port and path kept; user info, fragment and query values masked.

    Query parameter names are kept (``?X-Amz-Signature=***``) because they tell a reader which
    kind of URL failed without revealing anything that grants access.
    """
    try:
        parsed = url if isinstance(url, URL) else URL(url, encoded=True)
    except (ValueError, TypeError):
        return "<unparseable URL>"
    if not parsed.absolute:
        # A relative reference has no authority to keep; its path is all that is safe.
        return parsed.path or "<relative URL>"
    origin = f"{parsed.scheme}://{parsed.raw_host or ''}"
    if parsed.explicit_port is not None:
        origin += f":{parsed.explicit_port}"
    text = origin + parsed.raw_path
    if parsed.query:
        text += "?" + "&".join(
            f"{name}={value if name in _SAFE_QUERY_PARAMS else MASK}"
            for name, value in parsed.query.items()
        )
    return _mask_secrets(text)


def redact_text(text: str) -> str:
    """``text`` with registered secrets, bearer tokens and URL query values masked."""
    if not text:
        return text
    text = _URL_IN_TEXT.sub(lambda match: redact_url(match.group(0)), text)
    text = _BEARER_IN_TEXT.sub(lambda match: match.group(1) + MASK, text)
    return _mask_secrets(text)


def _mask_secrets(text: str) -> str:
    for secret in _secrets:
        if secret in text:
            text = text.replace(secret, MASK)
    return text
