"""Trino's functions as stook computes them: the allow-list of a metric's query.

A metric's query is Trino SQL. Each function it may call is either

- in `SAME`: sqlglot's Trino-to-DuckDB translation already gives Trino's value, or
- rewritten (`_sql`'s rewrites, and `REWRITTEN_BY_NAME`) into one of the `MACROS`
  below, which compute what Trino computes where DuckDB differs: a NULL where DuckDB
  gives '', Java's text of a DOUBLE, decimal arithmetic, rounding, 0-or-1-based
  positions, errors Trino raises.

The conformance corpus in the tests holds cases for each. A function that is in neither
is refused by name before anything runs: a DuckDB function that is not Trino's
(`read_text`, `getenv`, ...; `REASONS` says why), and a Trino function whose value stook
does not reproduce. The macros decide by DuckDB's own type of their argument when the
query binds (`typeof` in a CASE whose branches all have the result's type, or a typed
overload), so a rewrite never guesses a type.
"""

from __future__ import annotations

import math
from decimal import ROUND_HALF_UP, Decimal, localcontext
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    import duckdb

# The sqlglot node (its class name) of each function whose DuckDB translation is
# Trino's value.
SAME: frozenset[str] = frozenset(
    {
        # operators sqlglot counts as functions
        "And",
        "Or",
        # conditionals and casts (CAST to VARCHAR and AVG/ROUND/division are rewritten)
        "Case",
        "If",
        "Coalesce",
        "Nullif",
        "Cast",
        "TryCast",
        "Greatest",
        "Least",
        "Exists",
        # math
        "Abs",
        "Sqrt",
        "Exp",
        "Ln",
        "Log",
        "Pow",
        "Floor",
        "Ceil",
        "Trunc",
        "Pi",
        "Degrees",
        "Radians",
        "Sin",
        "Cos",
        "Tan",
        "Asin",
        "Acos",
        "Atan",
        "Atan2",
        "IsNan",
        # strings
        "Length",
        "Lower",
        "Upper",
        "Concat",
        "ConcatWs",
        "Replace",
        "Reverse",
        "StrPosition",
        "StartsWith",
        "Pad",
        "Chr",
        "RegexpLike",
        "Levenshtein",
        # aggregates
        "Count",
        "CountIf",
        "Sum",
        "Min",
        "Max",
        "AnyValue",
        "ArgMin",
        "ArgMax",
        "Stddev",
        "StddevSamp",
        "StddevPop",
        "Variance",
        "VariancePop",
        "LogicalAnd",
        "LogicalOr",
        "ApproxQuantile",
        "ArrayAgg",
        "Corr",
        "CovarSamp",
        "CovarPop",
        # window functions
        "RowNumber",
        "Rank",
        "DenseRank",
        "PercentRank",
        "CumeDist",
        "Ntile",
        "Lag",
        "Lead",
        "FirstValue",
        "LastValue",
        "NthValue",
        # arrays and lambdas
        "Array",
        "ArraySize",
        "ArrayContains",
        "ArrayPosition",
        "ArrayFilter",
        "Transform",
        "ArrayMax",
        "ArrayMin",
        "ArraySort",
        "ArrayToString",
        "Unnest",
        "Explode",
        # dates and times (session time zone UTC, as the platform's)
        "UnixToTime",
        "TimeToStr",  # date_format, its pattern checked (DATE_FORMAT_SPECIFIERS)
        "CurrentTimestamp",  # the platform's "now" too: a query using it is not repeatable
        "CurrentDate",
        "TimestampTrunc",
        "DateAdd",
        "TimeToUnix",
        "Extract",
        "Year",
        "Month",
        "Day",
        "Hour",
        "Minute",
        "Second",
    }
)

# date_format's MySQL specifiers as sqlglot translates them to strftime's (%i -> %M,
# %M -> %B, %e -> %-d, ...): those whose DuckDB text is Trino's. A pattern with another
# (%U, %u, %V, %X, ...) is refused.
DATE_FORMAT_SPECIFIERS: frozenset[str] = frozenset(
    [
        "%Y",
        "%y",
        "%m",
        "%-m",
        "%d",
        "%-d",
        "%H",
        "%-H",
        "%I",
        "%-I",
        "%M",
        "%S",
        "%p",
        "%j",
        "%B",
        "%b",
        "%A",
        "%a",
        "%f",
        "%%",
    ]
)

# Functions sqlglot does not know (exp.Anonymous), by their Trino name, each replaced by
# the macro of the same name with the `trino_` prefix.
REWRITTEN_BY_NAME: frozenset[str] = frozenset(
    {"human_readable_seconds", "is_finite", "is_infinite", "nan", "infinity"}
)

# Why a DuckDB function a Trino query cannot mean is refused, said to the user.
REASONS: dict[str, str] = {
    name: "it reads files or URLs; a metric's query reads only its tables"
    for name in (
        "read_text",
        "read_blob",
        "read_csv",
        "read_csv_auto",
        "read_json",
        "read_json_auto",
        "read_json_objects",
        "read_ndjson",
        "read_ndjson_auto",
        "read_ndjson_objects",
        "read_parquet",
        "parquet_scan",
        "parquet_metadata",
        "parquet_schema",
        "glob",
        "sniff_csv",
        "iceberg_scan",
        "delta_scan",
        "sqlite_scan",
    )
} | {
    name: "it reads the machine's settings or environment; a metric's query reads only its tables"
    for name in ("getenv", "current_setting", "duckdb_settings", "current_schema", "version")
}

# Each macro: DuckDB SQL giving Trino's value. Typed parameter overloads dispatch on the
# argument's DuckDB type (an unused typed parameter is never evaluated).
_INTEGERS = ("TINYINT", "SMALLINT", "INTEGER", "BIGINT", "HUGEINT")
_NUMBERS = (*_INTEGERS, "FLOAT", "DOUBLE")
# Java's Character.isWhitespace, as an RE2 character class body.
_JAVA_SPACE = (
    r"\t\n\x0B\f\r\x1C-\x1F \x{1680}\x{2000}-\x{2006}\x{2008}-\x{200A}\x{2028}\x{2029}"
    r"\x{205F}\x{3000}"
)


def _overloads(name: str, params: str, bodies: dict[str, str], fallback: str) -> str:
    """CREATE MACRO `name`(t <type>, `params`) per body, and an untyped fallback."""
    parts = [f"(t {typ}, {params}) AS {body}" for typ, body in bodies.items()]
    parts.append(f"(t, {params}) AS {fallback}")
    return f"CREATE MACRO {name} " + ", ".join(parts)


MACROS: tuple[str, ...] = (
    "CREATE MACRO trino_java_round(a) AS "
    "CASE WHEN a - floor(a) >= 0.5 THEN floor(a) + 1 ELSE floor(a) END",
    # Math.round(x * 10^d) / 10^d on the magnitude, as Trino's round(double, integer).
    "CREATE MACRO trino_round_double(x, d) AS CASE WHEN isnan(x) OR isinf(x) THEN x "
    "ELSE sign(x) * trino_java_round(abs(x) * pow(10, d)) / pow(10, d) END",
    # round(x, d) keeps x's type (a DECIMAL its scale, one more digit: x * 1); a
    # DOUBLE as Trino rounds one.
    "CREATE MACRO trino_round(x, d) AS CASE WHEN typeof(x) IN ('DOUBLE', 'FLOAT') "
    "THEN cast_to_type(trino_round_double(x, d), x * 1) ELSE cast_to_type(round(x, d), x * 1) "
    "END",
    "CREATE MACRO trino_round0(x) AS CASE WHEN typeof(x) IN ('DOUBLE', 'FLOAT') "
    "THEN cast_to_type(trino_round_double(x, 0), round(x)) ELSE round(x) END",
    # CAST(x AS <integer type>): a DOUBLE rounds half away from zero (DuckDB's to even).
    "CREATE MACRO trino_integral(x) AS CASE WHEN typeof(x) IN ('DOUBLE', 'FLOAT') "
    "THEN cast_to_type(trino_round_double(TRY_CAST(x AS DOUBLE), 0), x) ELSE x END",
    # x[i] past either end raises (DuckDB's gives NULL); v is DuckDB's x[i].
    "CREATE MACRO trino_subscript(x, i, v) AS CASE "
    "WHEN i > len(x) THEN error('Array subscript must be less than or equal to array length') "
    "WHEN i < 1 THEN error('Array subscript must be positive') ELSE v END",
    # || and concat take VARCHAR (or arrays) in Trino; DuckDB would print a number.
    "CREATE MACRO trino_text(x) AS CASE WHEN typeof(x) IN ('VARCHAR', '\"NULL\"') "
    "OR typeof(x) LIKE '%[]' THEN x ELSE error('|| and concat take VARCHAR in Trino, not ' "
    "|| typeof(x) || ' (CAST it to VARCHAR)') END",
    # array_max, array_min: NULL when an element is NULL; contains: NULL when absent
    # but a NULL is there.
    "CREATE MACRO trino_has_null(x) AS len(list_filter(x, lambda e: e IS NULL)) > 0",
    "CREATE MACRO trino_array_max(x) AS CASE WHEN NOT trino_has_null(x) THEN list_max(x) END",
    "CREATE MACRO trino_array_min(x) AS CASE WHEN NOT trino_has_null(x) THEN list_min(x) END",
    "CREATE MACRO trino_contains(x, e) AS CASE WHEN e IS NULL THEN NULL "
    "WHEN list_contains(x, e) THEN true WHEN trino_has_null(x) THEN NULL "
    "WHEN x IS NOT NULL THEN false END",
    # array_position: 0, not NULL, where the element is absent.
    "CREATE MACRO trino_array_position(x, e) AS "
    "CASE WHEN x IS NOT NULL THEN coalesce(array_position(x, e), 0) END",
    # A DOUBLE's text in Trino: Java's Double.toString digits, always in scientific
    # form (3.77E1, 1.2E3, 0E0, -0E0, 1E-3). Those are the fewest digits that read back
    # as the value, DuckDB's text's digits; but when that is one digit, the closest of
    # one or two digits (printf's correctly rounded two: 4.9E-324, not 5E-324). From
    # the text: its sign, its digits and the power of ten of the first one, each bound
    # once by a lambda (a macro argument is copied wherever it is used). In SQL, not a
    # Python function: a column of a million distinct values takes about 5 s.
    "CREATE MACRO trino_sci(u) AS list_transform([regexp_extract(u, "
    "'^(-?)([0-9]*)\\.?([0-9]*)(?:e([-+]?[0-9]+))?$', ['s', 'i', 'f', 'e'])], "
    "lambda p: list_transform([ltrim(p.i || p.f, '0')], lambda z: CASE WHEN z = '' "
    "THEN p.s || '0E0' ELSE list_transform([rtrim(z, '0')], lambda d: p.s || d[1] "
    "|| CASE WHEN length(d) > 1 THEN '.' || d[2:] ELSE '' END || 'E' "
    "|| CAST(coalesce(TRY_CAST(p.e AS INTEGER), 0) + length(p.i) - 1 "
    "- (length(p.i || p.f) - length(z)) AS VARCHAR))[1] END)[1])[1]",
    "CREATE MACRO trino_double_text(x) AS CASE WHEN isnan(x) THEN 'NaN' "
    "WHEN isinf(x) THEN CASE WHEN x > 0 THEN 'Infinity' ELSE '-Infinity' END "
    "ELSE list_transform([trino_sci(CAST(x AS VARCHAR))], lambda r: "
    "CASE WHEN regexp_full_match(r, '-?[0-9]E.*') THEN trino_sci(printf('%.1e', x)) "
    "ELSE r END)[1] END",
    # CAST(x AS VARCHAR): a DOUBLE as Java's Double.toString in scientific form; the
    # types whose text is DuckDB's as is; the rest refused.
    "CREATE MACRO trino_varchar(x) AS CASE "
    "WHEN typeof(x) = 'DOUBLE' THEN trino_double_text(TRY_CAST(x AS DOUBLE)) "
    "WHEN typeof(x) = 'FLOAT' THEN error('CAST of a REAL to VARCHAR: stook does not "
    "reproduce Trino''s text for it') "
    f"WHEN typeof(x) IN ({', '.join(repr(t) for t in (*_INTEGERS, 'VARCHAR', 'BOOLEAN', 'DATE'))}) "
    "OR typeof(x) LIKE 'DECIMAL%' THEN CAST(x AS VARCHAR) "
    "ELSE error('CAST of a ' || typeof(x) || ' to VARCHAR: stook does not reproduce "
    "Trino''s text for it') END",
    # a / b: integers give an integer, truncated toward zero, and raise on a zero
    # divisor; a DECIMAL quotient has the larger scale, rounded half up; a DOUBLE's is
    # IEEE's (Infinity, NaN). Every branch is of a + b's type, the quotient's in Trino.
    "CREATE MACRO trino_divide(a, b) AS CASE WHEN typeof(a + b) LIKE 'DECIMAL%' "
    "THEN cast_to_type(trino_decimal_quotient(CAST(a AS VARCHAR), CAST(b AS VARCHAR)), a + b) "
    f"WHEN typeof(a + b) IN ({', '.join(repr(t) for t in _INTEGERS)}) "
    "THEN cast_to_type(a // b, a + b) "
    "ELSE cast_to_type(a / b, a + b) END",
    # AVG: of a DECIMAL, a DECIMAL of its scale rounded half up; else a DOUBLE (the
    # sum is taken over DOUBLEs, see trino_avg_input).
    _overloads(
        "trino_avg_input",
        "x",
        {"DECIMAL": "x", "DOUBLE": "x", **{typ: "CAST(x AS DOUBLE)" for typ in _INTEGERS}},
        "x",
    ),
    "CREATE MACRO trino_avg(s, n) AS CASE WHEN typeof(s) LIKE 'DECIMAL%' "
    "THEN cast_to_type(trino_decimal_quotient(CAST(s AS VARCHAR), CAST(n AS VARCHAR)), s) "
    "ELSE cast_to_type(CAST(s AS DOUBLE) / n, s) END",
    # SUM of integers is a BIGINT in Trino (DuckDB's is a HUGEINT): overflow raises.
    "CREATE MACRO trino_sum(s) AS CASE WHEN typeof(s) = 'HUGEINT' "
    "THEN CAST(CAST(s AS BIGINT) AS HUGEINT) ELSE s END",
    # NULL, not '', where nothing matches or the part is beyond the last.
    "CREATE MACRO trino_regexp_extract(s, p, g) AS "
    "CASE WHEN regexp_matches(s, p) THEN regexp_extract(s, p, g) END",
    "CREATE MACRO trino_split_part(s, d, i) AS CASE "
    "WHEN i < 1 THEN error('Index must be greater than zero') "
    "WHEN i <= len(string_split(s, d)) THEN split_part(s, d, i) END",
    # substr: start 0 or beyond either end gives ''; a negative start counts from the end.
    "CREATE MACRO trino_substr(s, start, n) AS CASE "
    "WHEN start = 0 OR n <= 0 OR start > length(s) OR length(s) + start + 1 <= 0 THEN '' "
    "WHEN start < 0 THEN substring(s, length(s) + start + 1, n) "
    "ELSE substring(s, start, n) END",
    # Java's whitespace (Character.isWhitespace), not only ' '.
    f"CREATE MACRO trino_trim(s) AS regexp_replace(s, '^[{_JAVA_SPACE}]+|[{_JAVA_SPACE}]+$', "
    "'', 'g')",
    f"CREATE MACRO trino_ltrim(s) AS regexp_replace(s, '^[{_JAVA_SPACE}]+', '')",
    f"CREATE MACRO trino_rtrim(s) AS regexp_replace(s, '[{_JAVA_SPACE}]+$', '')",
    # width_bucket(x, bound1, bound2, n): buckets over [min, max), counted from bound1.
    "CREATE MACRO trino_bucket_up(x, lo, hi, n) AS CASE WHEN x < lo THEN 0 "
    "WHEN x >= hi THEN n + 1 "
    "ELSE CAST(trunc(CAST(n AS DOUBLE) * (x - lo) / (hi - lo)) AS BIGINT) + 1 END",
    "CREATE MACRO trino_width_bucket(x, b1, b2, n) AS CASE "
    "WHEN n <= 0 THEN error('bucketCount must be greater than 0') "
    "WHEN isnan(x) THEN error('operand must not be NaN') "
    "WHEN NOT isfinite(b1) THEN error('first bound must be finite') "
    "WHEN NOT isfinite(b2) THEN error('second bound must be finite') "
    "WHEN b1 = b2 THEN error('bounds cannot equal each other') "
    "WHEN b1 > b2 THEN n - trino_bucket_up(x, b2, b1, n) + 1 "
    "ELSE trino_bucket_up(x, b1, b2, n) END",
    "CREATE MACRO trino_is_finite(x) AS isfinite(CAST(x AS DOUBLE))",
    "CREATE MACRO trino_is_infinite(x) AS isinf(CAST(x AS DOUBLE))",
    "CREATE MACRO trino_nan() AS CAST('NaN' AS DOUBLE)",
    "CREATE MACRO trino_infinity() AS CAST('Infinity' AS DOUBLE)",
    "CREATE MACRO trino_human_readable_seconds(x) AS trino_readable_seconds(CAST(x AS DOUBLE))",
)


def install(con: duckdb.DuckDBPyConnection) -> None:
    """The macros and the two Python functions they call, on `con` (before its
    configuration is locked)."""
    con.create_function(
        "trino_decimal_quotient",
        decimal_quotient,
        ["VARCHAR", "VARCHAR"],
        "VARCHAR",
        side_effects=False,
    )
    con.create_function(
        "trino_readable_seconds", readable_seconds, ["DOUBLE"], "VARCHAR", side_effects=False
    )
    for macro in MACROS:
        con.execute(macro)


def decimal_quotient(dividend: str, divisor: str) -> str:
    """`dividend / divisor` (DECIMAL or integer text) at the larger of their scales,
    rounded half up, as Trino divides decimals; a zero divisor raises."""
    a, b = Decimal(dividend), Decimal(divisor)
    if b == 0:
        raise ZeroDivisionError("Division by zero")
    scale = max(-int(a.as_tuple().exponent), -int(b.as_tuple().exponent), 0)
    with localcontext() as context:
        context.prec = 80  # DECIMAL(38) divided: exact before the rounding
        quotient = (a / b).quantize(Decimal(1).scaleb(-scale), rounding=ROUND_HALF_UP)
    return f"{quotient:f}"


_UNITS = (("week", 604800), ("day", 86400), ("hour", 3600), ("minute", 60), ("second", 1))


def readable_seconds(seconds: float) -> str:
    """human_readable_seconds: whole weeks, days, hours, minutes and seconds, the
    fraction rounded half up (Trino: 96 -> '1 minute, 36 seconds')."""
    if math.isnan(seconds) or math.isinf(seconds):
        raise ValueError(f"Invalid argument found: {seconds}")
    left = int(Decimal(repr(abs(seconds))).quantize(Decimal(1), rounding=ROUND_HALF_UP))
    parts = []
    for unit, size in _UNITS:
        count, left = divmod(left, size)
        if count:
            parts.append(f"{count} {unit}{'' if count == 1 else 's'}")
    return ", ".join(parts) or "0 seconds"
