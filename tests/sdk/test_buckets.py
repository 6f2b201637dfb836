"""Histogram buckets: equal-width edges that end exactly at the bounds, and refusals."""

from __future__ import annotations

import itertools
import math

import pytest

from stook.sdk import MetricsWriter, WriterError, data, find_problems
from stook.sdk._writer import histogram_buckets
from tests.sdk.support import JOB, writer_error


def test_histogram_buckets_helper_ends_exactly_at_upper() -> None:
    edges = histogram_buckets("h", 3, 0.0, 0.3)
    assert len(edges) == 3
    assert edges[0][0] == 0.0
    assert edges[-1][1] == 0.3
    assert all(a[1] == b[0] for a, b in itertools.pairwise(edges))


def test_equal_width_buckets_that_round_to_empty_are_refused() -> None:
    w = MetricsWriter(JOB)
    values = data.doubles("v", [1e16])
    try:
        w.histogram("h", values, buckets=8, lower=1e16, upper=1e16 + 4)
    except WriterError:
        return
    assert find_problems(w.to_proto()) == []


@pytest.mark.parametrize(
    ("buckets", "lower", "upper", "message"),
    [
        (4, 1.0, 1.0, "metric 'h': 4 buckets need lower < upper and a count of at least 1"),
        (4, 2.0, 1.0, "metric 'h': 4 buckets need lower < upper and a count of at least 1"),
        (0, 0.0, 1.0, "metric 'h': 0 buckets need lower < upper and a count of at least 1"),
        (4, None, 1.0, "metric 'h': 4 buckets need lower < upper and a count of at least 1"),
        (4, 0.0, None, "metric 'h': 4 buckets need lower < upper and a count of at least 1"),
        ([], None, None, "metric 'h': a histogram needs at least one bucket"),
        ([(1.0, 1.0)], None, None, "metric 'h': bucket 0 has lower 1.0 >= upper 1.0"),
        ([(0.0, 1.0), (2.0, 1.5)], None, None, "metric 'h': bucket 1 has lower 2.0 >= upper 1.5"),
        ([(0.0, math.nan)], None, None, "metric 'h': bucket 0 has lower 0.0 >= upper nan"),
        (
            [(0.0, 1.0), (1.5, 2.0)],
            None,
            None,
            "metric 'h': bucket 1 starts at 1.5 but bucket 0 ends at 1.0",
        ),
        ([(0.0, 1.0)], -1.0, None, "metric 'h': lower/upper must match the first and last bucket"),
        ([(0.0, 1.0)], None, 2.0, "metric 'h': lower/upper must match the first and last bucket"),
    ],
)
def test_bucket_errors(
    buckets: object, lower: float | None, upper: float | None, message: str
) -> None:
    w = MetricsWriter(JOB)
    with writer_error(message):
        w.histogram("h", data.doubles("v", [1.0]), buckets=buckets, lower=lower, upper=upper)  # type: ignore[arg-type]
