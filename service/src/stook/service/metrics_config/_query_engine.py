"""The SQL engine: DuckDB in this process, over the topic and metadata frames.

Queries are written in Trino SQL (the platform's) and transpiled by sqlglot. DuckDB
runs single-threaded here: a query without ORDER BY (a GROUP BY, say) then returns its
rows in one order every run, which keeps metrics.binproto byte-identical.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from stook.service.metrics_config._errors import QueryError
from stook.service.metrics_config._sql import to_duckdb

if TYPE_CHECKING:
    from types import TracebackType

    from stook.service.metrics_config._emissions import Tables


@dataclass(frozen=True, slots=True)
class Result:
    """A query's result: its column names (the aliases) and rows, in order."""

    columns: list[str]
    rows: list[tuple[Any, ...]]

    def column(self, index: int) -> list[Any]:
        return [row[index] for row in self.rows]

    @property
    def no_data(self) -> bool:
        """No row, or only NULLs (what `MIN(x)` over nothing returns)."""
        return all(value is None for row in self.rows for value in row)


class QueryEngine:
    """One DuckDB connection with the tables registered; use as a context manager."""

    def __init__(self, tables: Tables) -> None:
        import duckdb

        # No progress bar: DuckDB draws one on the terminal for a query over 2 s.
        self._con = duckdb.connect(":memory:", config={"threads": 1})
        self._con.execute("SET enable_progress_bar = false")
        # Copied into DuckDB's own tables once: a registered frame is scanned through
        # Arrow by every query, 3-6x slower on the benchmark's queries.
        for name, frame in tables.items():
            self._con.register("incoming", frame)
            self._con.execute(f"CREATE TABLE {_quote(name)} AS SELECT * FROM incoming")
            self._con.unregister("incoming")

    def run(
        self, metric: str, query: str, params: Sequence[Any] = (), *, what: str = "query"
    ) -> Result:
        """Run Trino SQL `query`; QueryError names the metric, shows the SQL and says why."""
        import duckdb

        sql = to_duckdb(query)
        try:
            cursor = self._con.execute(sql, list(params))
            columns = [d[0] for d in cursor.description or ()]
            rows = cursor.fetchall()
        except duckdb.Error as exc:
            raise QueryError(metric, query.strip(), _message(exc), what=what) from None
        return Result(columns, rows)

    def bind(self, query: str) -> str | None:
        """Why `query` does not bind against the tables (None: it does); nothing runs."""
        import duckdb

        try:
            self._con.execute("PREPARE bound AS " + to_duckdb(query))
            self._con.execute("DEALLOCATE bound")
        except duckdb.Error as exc:
            return _message(exc)
        return None

    def close(self) -> None:
        self._con.close()

    def __enter__(self) -> QueryEngine:
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.close()


def _message(exc: Exception) -> str:
    """DuckDB's message without the transpiled SQL it quotes below it (the error shows
    the query as written)."""
    lines = str(exc).strip().splitlines()
    return lines[0] if lines else type(exc).__name__


def _quote(name: str) -> str:
    return '"' + name.replace('"', '""') + '"'
