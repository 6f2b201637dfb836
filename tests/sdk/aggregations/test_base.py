"""What every aggregation inherits: `fresh` keeps the configuration and drops the state."""

from __future__ import annotations

from stook.sdk.aggregations import MergedHistogram, ScalarStats
from tests.sdk.aggregations.support import fold, job


def test_fresh_keeps_configuration_and_drops_state() -> None:
    agg = fold(
        MergedHistogram(name="H", data="d", lower=0, upper=2, buckets=2, max_values=1),
        [job(series={"d": [0.5, 1.5]})],
    )
    assert isinstance(agg, MergedHistogram)
    assert agg.binned
    new = agg.fresh()
    assert (new.name, new.data, new.lower, new.upper, new.buckets, new.max_values) == (
        "H",
        "d",
        0,
        2,
        2,
        1,
    )
    assert (new.total, new.counts, new.arrays, new.jobs) == (0, None, [], 0)
    stats = fold(ScalarStats(metric="x", stats=["max"], name="X"), [job(scalars={"x": 1.0})])
    fresh_stats = stats.fresh()
    assert isinstance(fresh_stats, ScalarStats)
    assert (fresh_stats.name, list(fresh_stats.stats), len(fresh_stats.values)) == ("X", ["max"], 0)
