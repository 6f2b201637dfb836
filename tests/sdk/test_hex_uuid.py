"""`hex_uuid`: the same UUID as ``uuid.UUID(hex=...)``, or the same error."""

from __future__ import annotations

import pickle
import uuid
from collections.abc import Callable

import pytest
from hypothesis import given
from hypothesis import strategies as st

from stook.sdk.fastpaths import hex_uuid

CANONICAL = "418e78d2-c5d6-576c-af09-0f8c761e8ee8"

# The forms outputs hold, and odd ones that int(…, 16) reads after the hyphens go (signs,
# underscores, spaces): each must come out as uuid.UUID reads it, or fail as it fails.
TEXTS = [
    CANONICAL,
    CANONICAL.upper(),
    CANONICAL.replace("-", ""),
    "418e-78d2c5d6576caf090f8c761e8ee8--",
    "{" + CANONICAL + "}",
    "urn:uuid:" + CANONICAL,
    "+" + CANONICAL.replace("-", "")[1:],
    " " + CANONICAL.replace("-", "")[1:],
    "418e_78d2c5d6576caf090f8c761e8ee",
    "00000000-0000-0000-0000-000000000000",
    "ffffffff-ffff-ffff-ffff-ffffffffffff",
    "",
    "zz",
    CANONICAL[:-1],
    CANONICAL + "0",
    CANONICAL.replace("e", "g"),
    "{" + CANONICAL[1:] + "}",
    "٠" * 32,  # Arabic-Indic zeros: int() reads them
]


def _outcome(read: Callable[[str], uuid.UUID], text: str) -> tuple[str, object]:
    try:
        ident = read(text)
    except ValueError as exc:  # the error is compared too
        return ("error", (type(exc), str(exc)))
    assert type(ident) is uuid.UUID
    return ("uuid", (ident, ident.int, ident.is_safe, hash(ident), repr(ident), str(ident)))


@pytest.mark.parametrize("text", TEXTS)
def test_reads_as_uuid_reads(text: str) -> None:
    assert _outcome(hex_uuid, text) == _outcome(lambda t: uuid.UUID(hex=t), text)


@given(st.text(alphabet="0123456789abcdefABCDEF-{}:urnid_+ x", max_size=45))
def test_any_text_reads_as_uuid_reads(text: str) -> None:
    assert _outcome(hex_uuid, text) == _outcome(lambda t: uuid.UUID(hex=t), text)


def test_is_a_uuid_like_any_other() -> None:
    ident = hex_uuid(CANONICAL)
    assert pickle.loads(pickle.dumps(ident)) == ident
    assert ident.version == 5
    assert {ident: 1}[uuid.UUID(CANONICAL)] == 1
    with pytest.raises(TypeError, match="immutable"):
        ident.int = 1  # type: ignore[misc]
