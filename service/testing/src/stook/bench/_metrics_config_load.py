"""Config-defined metrics in this process: emissions loaded, and the batch queries run.

Issue 30's size: 1,000 jobs x 1,000 emitted rows, written as real emission files (ReSim's
line format, the fixture config's `speed` topic, generated from the job and row numbers
alone). Per run, interleaved so that a busy machine slows both alike:

- `EmissionsSet` (every row checked against its topic's schema, one frame per topic)
  against DuckDB's own `read_json` over the same files (no check, types guessed, one
  frame of structs): rows/s of each;
- the fixture config's batch metrics evaluated over the loaded tables, as batch mode
  does (`evaluate`: the tables into DuckDB, each metric's query and status queries,
  the rendering): queries/s.
"""

from __future__ import annotations

import statistics
import tempfile
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any, Final

from stook.sdk import MetricsWriter
from stook.service.metrics_config import (
    EmissionsSet,
    JobMeta,
    MetricsConfig,
    Tables,
    evaluate,
    load_config,
)
from stook.testing.metrics_config_fixture import write_fixture

__all__ = ["measure_metrics_config_load", "write_jobs"]

JOBS: Final = 1000
ROWS: Final = 1000
RUNS: Final = 3
QUICK_JOBS: Final = 50
QUICK_ROWS: Final = 200
QUICK_RUNS: Final = 1


def write_jobs(folder: Path, jobs: int, rows: int) -> list[Path]:
    """`jobs` folders under `folder`, each with an emissions.resim.jsonl of `rows` rows."""
    paths = []
    for k in range(jobs):
        lines = [
            f'{{"$metadata": {{"topic": "speed", "timestamp": {i * 10_000_000}}}, '
            f'"$data": {{"lane": "{"lr"[i % 2]}", "speed": {5.0 + (i * k) % 23!r}}}}}'
            for i in range(rows)
        ]
        path = folder / f"job-{k}" / "emissions.resim.jsonl"
        path.parent.mkdir(parents=True)
        path.write_text("\n".join(lines) + "\n", encoding="utf-8")
        paths.append(path)
    return paths


def _load(config: MetricsConfig, paths: list[Path]) -> dict[str, Any]:
    emissions = EmissionsSet(config)
    for k, path in enumerate(paths):
        emissions.add_job(JobMeta(job_id=f"job-{k}", experience_name=f"e{k}"), path)
    return emissions.tables()


def _read_json(folder: Path) -> int:
    import duckdb

    glob = str(folder / "*" / "emissions.resim.jsonl").replace("'", "''")
    with duckdb.connect(":memory:") as con:
        con.execute("SET enable_progress_bar = false")
        relation: Any = con.sql(f"SELECT * FROM read_json('{glob}', format='newline_delimited')")
        return int(relation.pl().height)


def _batch_queries(config: MetricsConfig) -> int:
    """How many queries the batch metrics run: each one's, and its status query once per
    threshold (at most: a crossed block threshold skips the warn one)."""
    queries = 0
    for metric in config.metrics_for("batch"):
        queries += 1
        if metric.status is not None:
            queries += sum(t is not None for t in (metric.status.block, metric.status.warn))
    return queries


def _evaluate(config: MetricsConfig, tables: Tables) -> int:
    writer = MetricsWriter(uuid.UUID(int=1), deterministic=True)
    return len(evaluate(config, tables, writer, level="batch").written)


def _timed(run: Callable[..., Any], *args: Any) -> tuple[float, Any]:
    started = time.perf_counter()
    got = run(*args)
    return time.perf_counter() - started, got


def measure_metrics_config_load(
    jobs: int = JOBS,
    rows: int = ROWS,
    runs: int = RUNS,
    *,
    say: Callable[[str], None] = print,
) -> dict[str, Any]:
    """Every run's seconds and the medians' rates: loading, read_json, batch queries."""
    load_s: list[float] = []
    read_json_s: list[float] = []
    query_s: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        config = load_config([write_fixture(folder / "repo")])
        paths = write_jobs(folder / "jobs", jobs, rows)
        queries = _batch_queries(config)
        _load(config, paths[:1])  # untimed: the first use imports polars and DuckDB
        for _ in range(runs):
            seconds, tables = _timed(_load, config, paths)
            load_s.append(seconds)
            loaded = tables["speed"].height
            seconds, read = _timed(_read_json, folder / "jobs")
            read_json_s.append(seconds)
            seconds, written = _timed(_evaluate, config, tables)
            query_s.append(seconds)
    if loaded != jobs * rows or read != jobs * rows:
        raise RuntimeError(f"loaded {loaded:,} and read {read:,} rows, not {jobs * rows:,}")
    total = jobs * rows
    load, read_json, query = (statistics.median(s) for s in (load_s, read_json_s, query_s))
    result = {
        "jobs": jobs,
        "rows_per_job": rows,
        "rows": total,
        "runs": runs,
        "load_runs_s": [round(s, 3) for s in load_s],
        "load_rows_per_s": round(total / load),
        "read_json_runs_s": [round(s, 3) for s in read_json_s],
        "read_json_rows_per_s": round(total / read_json),
        "batch_metrics": written,
        "batch_queries": queries,
        "query_runs_s": [round(s, 3) for s in query_s],
        "queries_per_s": round(queries / query, 2),
    }
    say(
        f"  {jobs:,} jobs x {rows:,} rows: EmissionsSet {load:.2f} s "
        f"({result['load_rows_per_s']:,} rows/s), DuckDB read_json {read_json:.2f} s "
        f"({result['read_json_rows_per_s']:,} rows/s); {written} batch metrics, {queries} "
        f"queries: {query:.2f} s ({result['queries_per_s']:g} queries/s); median of {runs}"
    )
    return result
