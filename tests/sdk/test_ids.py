"""The writer's IDs: derived from names (deterministic) or random, and never colliding."""

from __future__ import annotations

import uuid

from stook.sdk import JobMetricsView, MetricsWriter, data, find_problems
from tests.sdk.support import JOB, OTHER_JOB, written


def _build(w: MetricsWriter) -> None:
    times = data.timestamps("T", [1, 2], id=uuid.UUID(int=77))
    speed = data.doubles("speed", [1.0, 2.0], index=times, id=uuid.UUID(int=78))
    w.double_over_time("dot", speed)
    w.scalar("s", 1.0)
    e = w.scalar("em", 2.0, event=True)
    e2 = w.scalar("em", 3.0, event=True)
    w.event("e", timestamp=5, metrics=[e])
    w.event("f", timestamp=6, metrics=[e2])
    w.add_data(data.strings("alone", ["x"]))


def _ids(view: JobMetricsView) -> set[uuid.UUID]:
    return {m.id for m in view.metrics} | {d.id for d in view.data} | {e.id for e in view.events}


def test_deterministic_ids_give_byte_identical_output() -> None:
    a = MetricsWriter(JOB, deterministic=True)
    b = MetricsWriter(str(JOB), deterministic=True)
    _build(a)
    _build(b)
    first = a.serialize()
    assert a.serialize() == first
    assert b.serialize() == first
    view = written(a)
    ids = _ids(view)
    # 4 metrics, 4 data (T, speed, its status series, alone), 2 events
    assert len(ids) == 4 + 4 + 2
    # IDs are derived from names, not taken from the data items.
    assert uuid.UUID(int=77) not in ids
    assert uuid.UUID(int=78) not in ids
    assert all(i.version == 5 for i in ids)


def test_deterministic_ids_differ_between_jobs() -> None:
    a = MetricsWriter(JOB, deterministic=True)
    b = MetricsWriter(OTHER_JOB, deterministic=True)
    _build(a)
    _build(b)
    assert a.serialize() != b.serialize()
    assert _ids(written(a)).isdisjoint(_ids(written(b)))


def test_random_ids_differ_between_writers_but_data_keeps_its_own_id() -> None:
    a = MetricsWriter(JOB)
    b = MetricsWriter(JOB)
    _build(a)
    _build(b)
    va, vb = written(a), written(b)
    assert {m.id for m in va.metrics}.isdisjoint({m.id for m in vb.metrics})
    assert {e.id for e in va.events}.isdisjoint({e.id for e in vb.events})
    assert all(i.version == 4 for i in {m.id for m in va.metrics})
    # Without determinism a data item's own id is used.
    assert va.data_by_name["T"].id == uuid.UUID(int=77)
    assert va.data_by_name["speed"].id == uuid.UUID(int=78)
    assert va.data_by_name["alone"].id != vb.data_by_name["alone"].id


def test_deterministic_ids_do_not_collide_for_names_with_a_hash_suffix() -> None:
    w = MetricsWriter(JOB, deterministic=True)
    a1 = w.scalar("a", 1.0, event=True)
    a2 = w.scalar("a", 2.0, event=True)
    w.scalar("a#2", 3.0)
    w.event("e1", timestamp=1, metrics=[a1])
    w.event("e2", timestamp=2, metrics=[a2])
    assert find_problems(w.to_proto()) == []
