"""Config-defined metrics: DuckDB (stook's engine) against polars' SQL, on real queries.

    python -m tools.bench_metrics_config              # 1,000 jobs x 1,000 rows
    python -m tools.bench_metrics_config --small      # 50 jobs x 200 rows: a quick check

The fixture's batch-style queries (CTEs, joins with metadata, windows, COUNT_IF,
APPROX_PERCENTILE, UNION ALL), transpiled by sqlglot, on DuckDB as evaluate runs them
(QueryEngine.run) and on polars' SQLContext: which run, whether their rows agree, and
their median times. The why of docs/metrics-config.md's engine choice; loading rates and
batch queries/s are `stook bench`'s (stook.bench._metrics_config_load).
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from collections.abc import Callable
from functools import partial
from pathlib import Path
from typing import Any

import polars as pl
import sqlglot

from stook.bench._metrics_config_load import write_jobs
from stook.service.metrics_config import EmissionsSet, JobMeta, load_config
from stook.service.metrics_config._query_engine import QueryEngine
from stook.testing.metrics_config_fixture import write_fixture

QUERIES = {
    "per-job max, joined with metadata (CTE, JOIN)": """
        WITH per_job AS (SELECT job_id, MAX(speed) AS top FROM speed GROUP BY job_id)
        SELECT m.experience_name AS "Experience", p.top AS "Max speed"
        FROM per_job p JOIN metadata m ON p.job_id = m.job_id ORDER BY 1""",
    "COUNT_IF over a subquery": """
        SELECT COUNT_IF(top > 25) AS "Jobs" FROM (
          SELECT job_id, MAX(speed) AS top FROM speed GROUP BY job_id)""",
    "LAG window": """
        WITH steps AS (SELECT speed - LAG(speed) OVER (PARTITION BY job_id, lane
          ORDER BY timestamp) AS jump FROM speed)
        SELECT MAX(jump) FROM steps""",
    "APPROX_PERCENTILE": "SELECT APPROX_PERCENTILE(speed, 0.5) FROM speed",
    "UNION ALL, CONCAT": """
        SELECT CONCAT('lane ', lane) AS "Lane", COUNT(*) AS "Rows" FROM speed GROUP BY 1
        UNION ALL SELECT 'all', COUNT(*) FROM speed ORDER BY 1""",
    "ARBITRARY, CAST AS VARCHAR, ||": """
        SELECT ARBITRARY(lane) AS "Any lane", CAST(COUNT(*) AS VARCHAR) || ' rows' AS "Rows"
        FROM speed WHERE lane = 'l'""",
    "GREATEST, COALESCE, metadata tags": """
        SELECT GREATEST(MAX(speed), 0) AS "Top", COALESCE(MAX(m.branch), 'none') AS "Branch"
        FROM speed s JOIN metadata m ON s.job_id = m.job_id""",
    "timestamp / 1E9, ROUND": """
        SELECT job_id, ROUND(MAX(timestamp / 1E9), 3) AS "Seconds" FROM speed
        GROUP BY job_id ORDER BY 1 LIMIT 5""",
}


def median_seconds(run: Callable[[], Any], repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        run()
        times.append(time.perf_counter() - start)
    return statistics.median(times)


def _close(got: list[tuple[Any, ...]], expected: list[tuple[Any, ...]]) -> bool:
    """Equal rows, floats to 1e-9 (the ARBITRARY row may pick another lane)."""
    if len(got) != len(expected):
        return False
    for a, b in zip(got, expected, strict=True):
        for x, y in zip(a, b, strict=True):
            if isinstance(x, float) and isinstance(y, float):
                if abs(x - y) > 1e-9 * max(1.0, abs(y)):
                    return False
            elif x != y:
                return False
    return True


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--small", action="store_true")
    args = parser.parse_args()
    jobs, rows = (50, 200) if args.small else (1000, 1000)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        config = load_config([write_fixture(folder / "repo")])
        paths = write_jobs(folder / "jobs", jobs, rows)
        emissions = EmissionsSet(config)
        for k, path in enumerate(paths):
            emissions.add_job(JobMeta(job_id=f"job-{k}", experience_name=f"e{k}"), path)
        print(f"{jobs} jobs x {rows} rows = {jobs * rows:,} rows")
        tables = emissions.tables()
        engine = QueryEngine(tables)  # what evaluate runs the queries on
        context = pl.SQLContext(frames=dict(tables))
        print("queries (median of 5):              DuckDB      polars SQL")
        for name, query in QUERIES.items():
            on_polars = sqlglot.transpile(query, read="trino", write="postgres")[0]
            expected = engine.run(name, query).rows
            duck = median_seconds(partial(engine.run, name, query), 5)
            try:
                got = context.execute(on_polars, eager=True).rows()
                took = median_seconds(partial(context.execute, on_polars, eager=True), 5)
                same = "same rows" if _close(got, expected) else f"DIFFERENT: {got[:2]}"
                polars = f"{took * 1000:8.1f} ms  {same}"
            except Exception as exc:  # the point: which queries polars cannot run
                polars = f"fails: {' '.join(str(exc).split())[:70]}"
            print(f"  {name[:34]:34} {duck * 1000:8.1f} ms  {polars}")


if __name__ == "__main__":
    main()
