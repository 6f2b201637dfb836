"""The fields' own readers: an ID read fast is the ID uuid.UUID reads, and fails as it does."""

from __future__ import annotations

import pickle
import random
import uuid

import pytest

from stook.service.api import ApiClient
from stook.service.api._fields import new_uuid, uuid_text

CANONICAL = "61fbd861-8d13-523b-9236-d0af9a8ecadb"


@pytest.mark.parametrize(
    "text",
    [
        CANONICAL,
        CANONICAL.upper(),
        CANONICAL.replace("-", ""),
        "{" + CANONICAL + "}",
        "urn:uuid:" + CANONICAL,
        "00000000-0000-0000-0000-000000000000",
        "ffffffff-ffff-ffff-ffff-ffffffffffff",
        "6-1fbd8618d13523b92-36d0af9a8ecadb",  # hyphens anywhere: uuid.UUID drops them all
        "61fbd861_8d13_523b_9236_d0af9a8e",  # int() reads underscores between digits
    ],
)
def test_an_id_reads_as_uuid_reads_it(text: str) -> None:
    ours, theirs = new_uuid(text), uuid.UUID(text)
    assert type(ours) is uuid.UUID
    assert ours == theirs
    assert hash(ours) == hash(theirs)
    assert repr(ours) == repr(theirs)
    assert ours.is_safe is theirs.is_safe
    assert pickle.dumps(ours) == pickle.dumps(theirs)
    with pytest.raises(TypeError, match="immutable"):
        ours.int = 0  # type: ignore[misc]


@pytest.mark.parametrize(
    "text",
    ["", "1234", CANONICAL + "0", CANONICAL[:-1] + "g", " " * 32, "-" + CANONICAL[1:], 3, None],
)
def test_what_is_no_id_fails_as_uuid_fails(text: object) -> None:
    with pytest.raises((ValueError, TypeError, AttributeError)) as expected:
        uuid.UUID(text)  # type: ignore[arg-type]
    with pytest.raises((ValueError, TypeError, AttributeError)) as caught:
        new_uuid(text)  # type: ignore[arg-type]
    assert type(caught.value) is type(expected.value)
    assert str(caught.value) == str(expected.value)


@pytest.mark.parametrize(
    "ident", [uuid.UUID(CANONICAL), uuid.UUID(int=0), uuid.UUID(int=2**128 - 1)]
)
def test_an_id_is_written_as_str_writes_it(ident: uuid.UUID) -> None:
    assert uuid_text(ident) == str(ident)
    assert uuid_text(ident) == str(ident)  # remembered, still the same
    assert uuid_text(uuid.UUID(int=ident.int ^ 1)) == str(uuid.UUID(int=ident.int ^ 1))


def test_ids_are_written_digit_for_digit_as_str_writes_them() -> None:
    rng = random.Random(13)
    for _ in range(500):
        ident = uuid.UUID(int=rng.getrandbits(rng.choice([8, 64, 127, 128])))
        assert uuid_text(ident) == str(ident)


def test_a_subclass_of_uuid_is_written_its_own_way() -> None:
    class Short(uuid.UUID):
        def __str__(self) -> str:
            return "short"

    assert uuid_text(Short(CANONICAL)) == "short"


def test_a_field_reader_reads_the_fields_of_an_item_in_order() -> None:
    import orjson

    keys = ("metricID", "name", "value")
    read = ApiClient.field_reader(keys)
    item = orjson.loads(b'{"value": 1.5, "other": 1, "metricID": "m", "name": null}')
    assert read(item) == ("m", None, 1.5)
    with pytest.raises(KeyError):
        read({"metricID": "m"})
    # Why it is made from orjson's keys: the item's own key objects, found by identity.
    (made,) = (key for key in item if key == "metricID")
    assert any(made is key for key in read.__reduce__()[1])
