"""Masking of the two secrets that reach stook: the API token (registered once, masked
wherever it appears) and presigned-URL signatures (every URL loses its query values, where
S3, GCS and Azure carry them)."""

from __future__ import annotations

import re
from typing import Final

from yarl import URL

MASK: Final = "***"
# Query parameters that carry no credential and tell a reader which page failed.
_SAFE_QUERY_PARAMS: Final = frozenset({"pageSize", "pageToken"})
# A secret this long is masked even inside a longer word; a shorter one only where it stands
# alone, so that a two-letter token does not cut "about" into "***out".
_SUBSTRING_SECRET_LENGTH: Final = 8
_secrets: dict[str, re.Pattern[str]] = {}
_URL_IN_TEXT: Final = re.compile(r"""https?://[^\s'"<>`]+""", re.IGNORECASE)
_TRAILING_PUNCTUATION: Final = ").,;:!?]}"
# A short lower-case word after "bearer" ("invalid bearer token") is prose, not a secret.
_BEARER_IN_TEXT: Final = re.compile(
    r"(Bearer\s+)(?!(?-i:[a-z]{1,10})(?![A-Za-z0-9._~+/=-]))[A-Za-z0-9._~+/=-]+", re.IGNORECASE
)


def register_secret(secret: str) -> None:
    """Mask ``secret`` wherever :func:`redact_text` (and so every log line) meets it: one
    under 8 characters where no letter or digit touches it (``token ab refused``)."""
    if not secret or secret in _secrets:
        return
    escaped = re.escape(secret)
    if len(secret) < _SUBSTRING_SECRET_LENGTH:
        escaped = f"(?<![A-Za-z0-9]){escaped}(?![A-Za-z0-9])"
    _secrets[secret] = re.compile(escaped)


def redact_url(url: str | URL) -> str:
    """The URL's scheme, host, port and path; user info and fragment dropped, query values
    masked (names kept: ``?X-Amz-Signature=***`` says which kind of URL failed)."""
    try:  # yarl parses the authority lazily: a bad port fails on first access
        parsed = url if isinstance(url, URL) else URL(url, encoded=True)
        if not parsed.absolute:
            return parsed.path or "<relative URL>"  # no authority: the path is all that is safe
        text = f"{parsed.scheme}://{parsed.raw_host or ''}"
        if parsed.explicit_port is not None:
            text += f":{parsed.explicit_port}"
    except (ValueError, TypeError):
        return "<unparseable URL>"
    text += parsed.raw_path
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
