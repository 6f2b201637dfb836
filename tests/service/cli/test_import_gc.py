"""`stook run`'s imports without cyclic garbage collection (stook.service.cli._import_gc)."""

from __future__ import annotations

import gc
from collections.abc import Iterator

import pytest

from stook.service.cli._import_gc import ImportsUncollected


@pytest.fixture(autouse=True)
def _collector_as_found() -> Iterator[None]:
    enabled, frozen = gc.isenabled(), gc.get_freeze_count()
    yield
    if gc.get_freeze_count() > frozen:
        gc.unfreeze()
    (gc.enable if enabled else gc.disable)()


def test_the_imports_run_uncollected_then_what_they_made_is_frozen_until_the_end() -> None:
    gc.enable()
    assert gc.get_freeze_count() == 0
    with ImportsUncollected() as imports:
        assert not gc.isenabled()
        made = [[] for _ in range(100)]
        imports.done()
        assert gc.isenabled()
        assert gc.get_freeze_count() >= len(made)
    assert gc.isenabled()
    assert gc.get_freeze_count() == 0


def test_a_failed_import_still_turns_the_collector_back_on() -> None:
    gc.enable()
    with pytest.raises(ImportError), ImportsUncollected():
        raise ImportError("no such module")
    assert gc.isenabled()
    assert gc.get_freeze_count() == 0


def test_objects_someone_else_froze_stay_frozen() -> None:
    gc.enable()
    gc.freeze()
    frozen = gc.get_freeze_count()
    with ImportsUncollected() as imports:
        imports.done()
    assert gc.get_freeze_count() >= frozen > 0


def test_a_collector_turned_off_stays_off() -> None:
    gc.disable()
    with ImportsUncollected() as imports:
        imports.done()
        assert not gc.isenabled()
    assert not gc.isenabled()
