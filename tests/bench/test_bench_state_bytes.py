"""stook.bench._state_bytes: the pickled bytes of each shard's partial states."""

from __future__ import annotations

import pickle
import subprocess
import sys

import pytest

from stook.bench._state_bytes import (
    main,
    measured_aggregations,
    shards_of,
    state_bytes,
    synthetic_jobs,
    table,
)
from stook.sdk import MetricsWriter
from tests.sdk.aggregations.support import BATCH_ID


def test_rows_are_the_pickled_sizes_of_each_shards_partials() -> None:
    jobs = synthetic_jobs(120)
    rows = state_bytes(jobs, 3)
    names = [row.aggregation for row in rows]
    assert names[-1] == "all of them, pickled together"
    assert len(rows) == len(measured_aggregations()) + 1
    assert all(row.shard_jobs == (40, 40, 40) for row in rows)
    # The same partials, pickled here, weigh what the rows say.
    partials = measured_aggregations()
    for record in shards_of(jobs, 3)[1]:
        for partial in partials:
            partial.update(record)
    for row, partial in zip(rows, partials, strict=False):
        assert row.shard_bytes[1] == len(pickle.dumps(partial, pickle.HIGHEST_PROTOCOL))
    assert rows[-1].shard_bytes[1] == len(pickle.dumps(partials, pickle.HIGHEST_PROTOCOL))
    by_name = {row.aggregation.split(" (")[0]: row for row in rows}
    assert by_name["PassRate"].shard_bytes[0] < 200
    assert by_name["MergedHistogram"].shard_bytes[0] < 2_000  # 10,089 values: counts mode


def test_synthetic_jobs_are_deterministic_and_fold_into_every_aggregation() -> None:
    first, again = synthetic_jobs(30), synthetic_jobs(30)
    assert [j.job_id for j in first] == [j.job_id for j in again]
    for partial in measured_aggregations():
        for record in first:
            partial.update(record)
        writer = MetricsWriter(BATCH_ID, deterministic=True)
        partial.finish(writer)
        assert writer.serialize()


def test_shards_split_the_jobs_in_consecutive_runs() -> None:
    jobs = synthetic_jobs(7)
    parts = shards_of(jobs, 3)
    assert [len(p) for p in parts] == [3, 3, 1]
    assert [j for p in parts for j in p] == jobs


@pytest.mark.slow
def test_the_command_prints_a_table() -> None:
    done = subprocess.run(
        [sys.executable, "-m", "stook.bench._state_bytes", "--jobs", "40", "--shards", "2"],
        capture_output=True,
        text=True,
        check=True,
    )
    assert done.stdout.startswith("40 synthetic jobs in 2 shards:")
    assert "| MergedHistogram (Speeds) |" in done.stdout
    bad = subprocess.run(
        [sys.executable, "-m", "stook.bench._state_bytes", "--shards", "0"],
        capture_output=True,
        text=True,
    )
    assert bad.returncode == 2
    assert "--jobs and --shards must be at least 1" in bad.stderr
    assert table([]).startswith("| Aggregation |")


def test_main_prints_the_table_in_process(capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["--jobs", "20", "--shards", "2"]) == 0
    out = capsys.readouterr().out
    assert out.startswith("20 synthetic jobs in 2 shards:")
    assert out.rstrip().endswith("|")
