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

# From this length on a secret is masked wherever it appears, even inside a longer word;
# real tokens are far longer. A shorter one is masked where it stands alone (see
# register_secret), so that a two-letter token does not cut "about" into "***out".
_SUBSTRING_SECRET_LENGTH: Final = 8
# What may touch a short secret on either side for it still to count as standing alone.
_WORD_CHAR: Final = "A-Za-z0-9"

# Each registered secret with the pattern that finds it.
_secrets: dict[str, re.Pattern[str]] = {}

_URL_IN_TEXT: Final = re.compile(r"""https?://[^\s'"<>`]+""", re.IGNORECASE)
_TRAILING_PUNCTUATION: Final = ").,;:!?]}"
# A short lower-case word after "bearer" ("invalid bearer token") is prose, not a secret;
# registered secrets are masked whatever their shape (see _mask_secrets).
_BEARER_IN_TEXT: Final = re.compile(
    r"(Bearer\s+)(?!(?-i:[a-z]{1,10})(?![A-Za-z0-9._~+/=-]))[A-Za-z0-9._~+/=-]+",
    re.IGNORECASE,
)


def register_secret(secret: str) -> None:
    """Mask ``secret`` wherever :func:`redact_text` (and so every log line) meets it.

    A secret of any length is masked. One of 8 characters or more is masked wherever it
    appears; a shorter one wherever it is not part of a longer run of letters and digits
    (``token ab refused``, ``"ab"``, ``/ab/``), since masking every "ab" would garble
    every message while a server that echoes a token echoes it as a token.
    """
    if not secret or secret in _secrets:
        return
    escaped = re.escape(secret)
    if len(secret) < _SUBSTRING_SECRET_LENGTH:
        escaped = f"(?<![{_WORD_CHAR}]){escaped}(?![{_WORD_CHAR}])"
    _secrets[secret] = re.compile(escaped)


def redact_url(url: str | URL) -> str:
    """The URL with scheme, host, port and path kept; user info, fragment and query values masked.

    Query parameter names are kept (``?X-Amz-Signature=***``) because they tell a reader which
    kind of URL failed without revealing anything that grants access.
    """
    # yarl parses the authority lazily: a bad port fails on first access, not in URL().
    try:
        parsed = url if isinstance(url, URL) else URL(url, encoded=True)
        if not parsed.absolute:
            # A relative reference has no authority to keep; its path is all that is safe.
            return parsed.path or "<relative URL>"
        origin = f"{parsed.scheme}://{parsed.raw_host or ''}"
        if parsed.explicit_port is not None:
            origin += f":{parsed.explicit_port}"
    except (ValueError, TypeError):
        return "<unparseable URL>"
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
    text = _URL_IN_TEXT.sub(_redact_url_in_text, text)
    text = _BEARER_IN_TEXT.sub(lambda match: match.group(1) + MASK, text)
    return _mask_secrets(text)


def _redact_url_in_text(match: re.Match[str]) -> str:
    # Prose closes a URL with punctuation ("(see http://host:4000).") that is not part of it.
    found = match.group(0)
    url = found.rstrip(_TRAILING_PUNCTUATION)
    return redact_url(url) + found[len(url) :]


def _mask_secrets(text: str) -> str:
    for secret, pattern in _secrets.items():
        if secret in text:
            text = pattern.sub(MASK, text)
    return text
