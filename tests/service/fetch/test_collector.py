"""A fetch runs with fewer garbage collections, and leaves the collector as it found it."""

from __future__ import annotations

import gc
from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.sdk.aggregations import Needs
from stook.service.api import ApiClient
from stook.service.fetch import ReportFetcher
from stook.service.fetch._collector import FETCH_GC_THRESHOLD, fewer_collections
from stook.testing import emulated_report


@pytest.fixture(autouse=True)
def collector_as_found() -> Iterator[None]:
    before = gc.get_threshold()
    frozen = gc.get_freeze_count()
    yield
    assert gc.get_threshold() == before
    assert gc.get_freeze_count() == frozen


def test_during_a_fetch_old_objects_are_frozen_and_young_collections_wait() -> None:
    before = gc.get_threshold()
    with fewer_collections():
        assert gc.get_threshold() == (FETCH_GC_THRESHOLD, *before[1:])
        assert gc.get_freeze_count() > 0
    assert gc.get_threshold() == before
    assert gc.get_freeze_count() == 0


def test_overlapping_fetches_restore_the_collector_when_the_last_ends() -> None:
    before = gc.get_threshold()
    outer = fewer_collections()
    inner = fewer_collections()
    outer.__enter__()
    inner.__enter__()
    outer.__exit__(None, None, None)  # not last in, first out: a baseline beside a candidate
    assert gc.get_threshold()[0] == FETCH_GC_THRESHOLD
    inner.__exit__(None, None, None)
    assert gc.get_threshold() == before


def test_a_failed_fetch_restores_the_collector() -> None:
    before = gc.get_threshold()
    with pytest.raises(RuntimeError), fewer_collections():
        raise RuntimeError("the fetch failed")
    assert gc.get_threshold() == before


def test_a_higher_threshold_someone_set_is_kept() -> None:
    before = gc.get_threshold()
    gc.set_threshold(FETCH_GC_THRESHOLD * 2, *before[1:])
    try:
        with fewer_collections():
            assert gc.get_threshold()[0] == FETCH_GC_THRESHOLD * 2
    finally:
        gc.set_threshold(*before)


def test_a_collector_turned_off_stays_off() -> None:
    before = gc.get_threshold()
    gc.set_threshold(0, *before[1:])
    try:
        with fewer_collections():
            assert gc.get_threshold()[0] == 0
    finally:
        gc.set_threshold(*before)


def test_objects_frozen_by_someone_else_stay_frozen() -> None:
    gc.freeze()
    try:
        frozen = gc.get_freeze_count()
        with fewer_collections():
            pass
        assert gc.get_freeze_count() == frozen
    finally:
        gc.unfreeze()


async def test_a_report_is_fetched_with_fewer_garbage_collections(tmp_path: Path) -> None:
    before = gc.get_threshold()
    seen: list[int] = []
    async with emulated_report(tmp_path, report_batches=2, report_jobs_per_batch=3) as emu:
        info = emu.info
        async with ApiClient(info.api_url, info.token) as api:
            fetcher = ReportFetcher(api, info.project_id, info.report_id, Needs())
            await fetcher.run(lambda batch: seen.append(gc.get_threshold()[0]))
    assert seen == [FETCH_GC_THRESHOLD, FETCH_GC_THRESHOLD]
    assert gc.get_threshold() == before
