"""Helpers for testing code written on stook.sdk (no pytest needed).

`check_merge_laws` checks in one line that an aggregation obeys the update/merge/finish
contract: however the records are split into partials, whatever order they arrive or
the partials merge in, ``finish`` writes the same bytes, and ``fresh()`` is empty. Every
partial is pickled and unpickled before it merges, as between worker processes.

    from stook.sdk.testing import check_merge_laws

    def test_my_aggregation_merges() -> None:
        check_merge_laws(lambda: MyAggregation(name="Mean speed"), records)

`MergeLaws` offers the single checks, for property-based tests that choose the splits.
"""

from stook.sdk._merge_laws import CHECK_JOB_ID, MergeLaws, check_merge_laws

__all__ = ["CHECK_JOB_ID", "MergeLaws", "check_merge_laws"]
