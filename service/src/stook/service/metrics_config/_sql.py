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
        return _describe(exc)
    if len(statements) != 1:
        return f"must be one statement, not {len(statements)}"
    if not isinstance(statements[0], exp.Query):
        # A metric reads the tables; a DROP or an INSERT would change them for the next.
        return f"must be a query (SELECT ...), not {statements[0].key.upper()}"
    if placeholders is not None:
        found = sum(1 for _ in statements[0].find_all(exp.Placeholder))
        if found != placeholders:
            return f"must have exactly {placeholders} '?' (the threshold), not {found}"
    return None


def to_duckdb(query: str) -> str:
    """`query` transpiled from Trino to DuckDB (checked by `parse_problem` beforehand)."""
    import sqlglot

    return sqlglot.transpile(query, read="trino", write="duckdb")[0]


def _describe(exc: Exception) -> str:
    """sqlglot's first error, without the terminal escapes it highlights the token with."""
    errors = getattr(exc, "errors", None)
    if errors:
        first = errors[0]
        where = (
            f" (line {first.get('line')}, column {first.get('col')})" if first.get("line") else ""
        )
        return f"{first.get('description')}{where}"
    return " ".join(str(exc).split())[:300]
