"""A topic's column types: how a row's JSON must look, and what the column becomes.

Rows are checked by their JSON *structure* (DuckDB's `json_structure`, one per row, then
grouped: a file has few distinct structures), so the check is exact -- `true` is no int,
`"1"` no float -- without a Python step per row.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    import polars as pl

# DuckDB's json_structure names of a value, per column type.
_ACCEPTED: dict[str, tuple[str, ...]] = {
    "boolean": ("BOOLEAN",),
    "int": ("BIGINT", "UBIGINT"),
    # ReSim's Emitter takes ints in a float column.
    "float": ("DOUBLE", "BIGINT", "UBIGINT"),
    "string": ("VARCHAR",),
    "status": ("VARCHAR",),
    "image": ("VARCHAR",),
    "video": ("VARCHAR",),
}

# The DuckDB type each column is read as, once checked.
DUCKDB_TYPES = {
    "boolean": "BOOLEAN",
    "int": "BIGINT",
    "float": "DOUBLE",
    "string": "VARCHAR",
    "status": "VARCHAR",
    "image": "VARCHAR",
    "video": "VARCHAR",
    "string[]": "VARCHAR[]",
    # metric[] entries ({name, type, value, unit?}) are free-form: kept as JSON text.
    "metric[]": "JSON[]",
}


def polars_type(kind: str) -> pl.DataType:
    """The polars type of a column of this type."""
    import polars as pl

    if kind == "boolean":
        return pl.Boolean()
    if kind == "int":
        return pl.Int64()
    if kind == "float":
        return pl.Float64()
    if kind in ("string[]", "metric[]"):
        return pl.List(pl.String())
    return pl.String()  # string, status, image, video


def value_problem(kind: str, structure: Any) -> str | None:
    """Why a value of this JSON structure is not a `kind` (None: it is)."""
    if structure == "NULL":
        return f"null is not a {kind}"
    if kind == "string[]":
        if isinstance(structure, list) and structure and structure[0] in ("VARCHAR", "NULL"):
            return None
        return f"expected a list of strings, got {_describe(structure)}"
    if kind == "metric[]":
        if isinstance(structure, list):
            return None
        return f"expected a list of metrics, got {_describe(structure)}"
    if isinstance(structure, str) and structure in _ACCEPTED[kind]:
        return None
    return f"expected {kind}, got {_describe(structure)}"


def _describe(structure: Any) -> str:
    if isinstance(structure, list):
        inner = _describe(structure[0]) if structure else "nothing"
        return f"a list of {inner}"
    if isinstance(structure, dict):
        return "an object"
    return {
        "VARCHAR": "a string",
        "BIGINT": "an int",
        "UBIGINT": "an int",
        "DOUBLE": "a float",
        "BOOLEAN": "a boolean",
        "NULL": "null",
        "JSON": "mixed types",
    }.get(str(structure), str(structure))
