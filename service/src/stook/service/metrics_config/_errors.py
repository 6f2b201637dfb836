"""The errors of config-defined metrics, each with the exit code `stook` gives it."""

from __future__ import annotations

from collections.abc import Sequence

from stook.sdk import StookError


class MetricsConfigError(StookError):
    """A config is unusable: bad YAML, a bad key, an unknown name, a query that does not
    parse or bind, a missing template (exit 2). One line per problem."""

    def __init__(self, problems: Sequence[str]) -> None:
        self.problems = list(problems)
        super().__init__("\n".join(self.problems))


class EmissionsError(StookError):
    """An emissions file cannot be read, or a row breaks its topic's schema (exit 4)."""


class QueryError(StookError):
    """A metric's query (or its status query) failed in the SQL engine (exit 4)."""

    def __init__(self, metric: str, sql: str, message: str, *, what: str = "query") -> None:
        self.metric = metric
        self.sql = sql
        super().__init__(f"metric {metric!r}: its {what} failed: {message}\n  SQL: {sql}")


class TemplateError(StookError):
    """A custom Liquid template failed to render, or did not print Plotly JSON (exit 4)."""
