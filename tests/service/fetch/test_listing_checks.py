"""`are_ids` takes exactly the IDs the regular expression for one ID takes, all of them."""

from __future__ import annotations

import random
import uuid

import pytest

from stook.service.fetch._listing_checks import ID_FULLMATCH, are_ids

IDS = [str(uuid.UUID(int=i * 7919 + 1)) for i in range(5)]


def expected(ids: list[str]) -> bool:
    return all(ID_FULLMATCH(i) is not None for i in ids)


@pytest.mark.parametrize(
    "ids",
    [
        [],
        IDS[:1],
        IDS,
        [IDS[0].upper(), IDS[1]],
        [""],
        [IDS[0], ""],
        [IDS[0] + "\n" + IDS[1]],
        [IDS[0] + "\n" + IDS[1], ""],
        [IDS[0][:-1], IDS[1] + "0"],
        [IDS[0][:-1] + "g"],
        [IDS[0][:-1] + "é"],
        [IDS[0][:-1] + "٣"],  # a digit, but not an ASCII one
        [IDS[0].replace("-", "")],
        ["{" + IDS[0][1:-1] + "}"],
        [IDS[0][:8] + "0" + IDS[0][9:]],  # a hyphen moved
        [IDS[0][:7] + "-" + IDS[0][8] + IDS[0][9:]],
        [IDS[0][:-1] + "\n", IDS[1]],
        [IDS[0][:-1] + " "],
        [IDS[0][:-2] + "-0"],
    ],
)
def test_ids_are_taken_as_the_expression_takes_them(ids: list[str]) -> None:
    assert are_ids(ids) is expected(ids)


def test_random_corruptions_are_taken_as_the_expression_takes_them() -> None:
    rng = random.Random(7)
    alphabet = "0123456789abcdefABCDEFgG-\n _{}é"
    for _ in range(5_000):
        ids = [str(uuid.UUID(int=rng.getrandbits(128))) for _ in range(rng.randint(1, 4))]
        for _ in range(rng.randint(0, 2)):
            which = rng.randrange(len(ids))
            chars = list(ids[which])
            match rng.randrange(3):
                case 0:
                    chars[rng.randrange(len(chars))] = rng.choice(alphabet)
                case 1:
                    del chars[rng.randrange(len(chars))]
                case _:
                    chars.insert(rng.randrange(len(chars) + 1), rng.choice(alphabet))
            ids[which] = "".join(chars)
        assert are_ids(ids) is expected(ids), ids


def test_ids_that_are_not_strings_are_refused() -> None:
    assert not are_ids([IDS[0], 3])  # type: ignore[list-item]
    assert not are_ids([None])  # type: ignore[list-item]
