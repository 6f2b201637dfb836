"""Trino SQL (the platform's dialect) into DuckDB's, with sqlglot."""

from __future__ import annotations


def parse_problem(query: str, *, placeholders: int | None = None) -> str | None:
    """What is wrong with `query` as Trino SQL (None: nothing); with `placeholders`, also
    whether it has exactly that many `?`."""
    import sqlglot
    from sqlglot import exp
    from sqlglot.errors import SqlglotError

    try:
        statements = [s for s in sqlglot.parse(query, read="trino") if s is not None]
    except SqlglotError as exc:
        return _first_line(str(exc))
    if len(statements) != 1:
        return f"must be one statement, not {len(statements)}"
    if placeholders is not None:
        found = sum(1 for _ in statements[0].find_all(exp.Placeholder))
        if found != placeholders:
            return f"must have exactly {placeholders} '?' (the threshold), not {found}"
    return None


def to_duckdb(query: str) -> str:
    """`query` transpiled from Trino to DuckDB (checked by `parse_problem` beforehand)."""
    import sqlglot

    return sqlglot.transpile(query, read="trino", write="duckdb")[0]


def _first_line(text: str) -> str:
    return " ".join(text.split())[:300]
