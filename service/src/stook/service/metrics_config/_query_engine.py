"""The SQL engine: DuckDB in this process, over the topic and metadata frames.

Queries are written in Trino SQL (the platform's), checked and translated by `_sql`.
DuckDB runs single-threaded here: a query without ORDER BY (a GROUP BY, say) then
returns its rows in one order every run, which keeps metrics.binproto byte-identical.

A query reaches its tables and nothing else, closed in the engine itself and not only
by `_sql`'s allow-list: no file or URL access (`enable_external_access`), no extension
installed or loaded, no Python variable read as a table, and the configuration locked
once the tables and Trino's functions are in, so no query can undo any of it.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from stook.service.metrics_config._errors import QueryError
from stook.service.metrics_config._sql import refusal, to_duckdb
from stook.service.metrics_config._trino_functions import install

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

        self._tables = tuple(tables)
        self._con = duckdb.connect(":memory:", config=_SETTINGS)
        # No progress bar: DuckDB draws one on the terminal for a query over 2 s.
        self._con.execute("SET enable_progress_bar = false")
        self._con.execute("SET TimeZone = 'UTC'")
        # Copied into DuckDB's own tables once: a registered frame is scanned through
        # Arrow by every query, 3-6x slower on the benchmark's queries.
        for name, frame in tables.items():
            self._con.register("incoming", frame)
            self._con.execute(f"CREATE TABLE {_quote(name)} AS SELECT * FROM incoming")
            self._con.unregister("incoming")
        install(self._con)
        self._con.execute("SET lock_configuration = true")

    def run(
        self, metric: str, query: str, params: Sequence[Any] = (), *, what: str = "query"
    ) -> Result:
        """Run Trino SQL `query`; QueryError names the metric, shows the SQL and says why."""
        import duckdb

        why = refusal(query, self._tables)
        if why is not None:
            raise QueryError(metric, query.strip(), f"refused: it {why}", what=what)
        sql = to_duckdb(query)
        try:
            cursor = self._con.execute(sql, list(params))
            columns = [d[0] for d in cursor.description or ()]
            rows = cursor.fetchall()
        except duckdb.Error as exc:
            raise QueryError(metric, query.strip(), _message(exc), what=what) from None
        return Result(columns, rows)

    def bind(self, query: str) -> str | None:
        """Why `query` is refused or does not bind against the tables (None: it binds);
        nothing runs."""
        import duckdb

        why = refusal(query, self._tables)
        if why is not None:
            return f"refused: it {why}"
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


_SETTINGS: dict[str, str | bool | int | float | list[str]] = {
    "threads": 1,
    # Nothing outside the tables: no file, folder or URL, no extension, no Python
    # variable picked up by name as a table.
    "enable_external_access": False,
    "autoinstall_known_extensions": False,
    "autoload_known_extensions": False,
    "allow_community_extensions": False,
    "python_enable_replacements": False,
    # Trino's: NULLs sort last whichever the direction (and the time zone, below, UTC).
    "default_null_order": "nulls_last",
}


def _message(exc: Exception) -> str:
    """DuckDB's message without the transpiled SQL it quotes below it (the error shows
    the query as written)."""
    lines = str(exc).strip().splitlines()
    return lines[0] if lines else type(exc).__name__


def _quote(name: str) -> str:
    return '"' + name.replace('"', '""') + '"'
