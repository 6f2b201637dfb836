"""A metric's query: Trino SQL (the platform's dialect), checked and put into DuckDB's.

Both steps work on sqlglot's tree of the query read as Trino:

- `refusal` says why stook will not run a query: it reads something other than its
  tables (a table function, a file or URL as a table, a qualified name, a statement
  that is not a query), or calls a function that is not on the allow-list of
  `_trino_functions` (which names the function and says why);
- `to_duckdb` rewrites what DuckDB computes differently into the macros that compute
  Trino's value, and writes the tree as DuckDB SQL.

The engine runs no query `refusal` has refused, in `check` and `eval` alike.
"""

from __future__ import annotations

from collections.abc import Callable, Collection
from typing import TYPE_CHECKING, Any

from stook.service.metrics_config._trino_functions import (
    DATE_FORMAT_SPECIFIERS,
    REASONS,
    REWRITTEN_BY_NAME,
    SAME,
)

if TYPE_CHECKING:
    from sqlglot import exp


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
        # Named by its first word: sqlglot reads some (INSTALL x) as other nodes.
        return f"must be a query (SELECT ...), not {query.split()[0].upper()}"
    if placeholders is not None:
        found = sum(1 for _ in statements[0].find_all(exp.Placeholder))
        if found != placeholders:
            return f"must have exactly {placeholders} '?' (the threshold), not {found}"
    return None


def refusal(query: str, tables: Collection[str]) -> str | None:
    """Why stook refuses to run `query` over `tables` (None: it runs it): every table it
    reads is one of `tables` or its own WITH name, and every function it calls is one
    stook computes as Trino does."""
    from sqlglot import exp

    problem = parse_problem(query)
    if problem is not None:
        return problem
    tree = _parse(query)
    known = {name.lower() for name in tables}
    known |= {cte.alias_or_name.lower() for cte in tree.find_all(exp.CTE)}
    for node in tree.walk():
        why = _node_refusal(node, known)
        if why is not None:
            return why
    return None


def to_duckdb(query: str) -> str:
    """`query` (not refused by `refusal`) as DuckDB SQL computing Trino's values."""
    tree = _parse(query)
    # Children first: a rewrite copies its arguments as they will run.
    for node in reversed(list(tree.walk(bfs=False))):
        rewrite = _REWRITES.get(type(node).__name__)
        if rewrite is not None and node.parent is not None:
            replacement = rewrite(node)
            if replacement is not node:
                node.replace(replacement)
    return tree.sql(dialect="duckdb")


def _parse(query: str) -> exp.Expr:
    import sqlglot

    return sqlglot.parse_one(query, read="trino")


def _node_refusal(node: exp.Expr, tables: set[str]) -> str | None:
    from sqlglot import exp

    if isinstance(node, exp.Table):
        if not isinstance(node.this, exp.Identifier):
            name = _function_name(node.this)
            why = REASONS.get(name, "a metric's query reads only its tables")
            return f"reads the table function {name}(): {why}"
        if node.args.get("db") or node.args.get("catalog"):
            return f"reads {node.sql(dialect='trino')}: a metric's query reads only its tables"
        if node.name.lower() not in tables:
            return (
                f"reads {node.name!r}, which is not one of its tables ({', '.join(sorted(tables))})"
            )
        return None
    if isinstance(node, (exp.Command, exp.Parameter, exp.SessionParameter)):
        return f"uses {node.sql(dialect='trino')!r}: a metric's query reads only its tables"
    if isinstance(node, exp.TimeToStr):
        return _date_format_refusal(node)
    if isinstance(node, exp.Func) and not _allowed(node):
        name = _function_name(node)
        why = REASONS.get(
            name,
            "stook does not compute it as Trino does (the functions it does are listed "
            "in docs/metrics-config.md)",
        )
        return f"calls {name}(): {why}"
    return None


def _date_format_refusal(node: exp.TimeToStr) -> str | None:
    """date_format's pattern must be a literal of specifiers DuckDB prints as Trino does."""
    import re

    from sqlglot import exp

    pattern = node.args.get("format")
    if not isinstance(pattern, exp.Literal) or not pattern.is_string:
        return "calls date_format() with a pattern that is not a literal string"
    for specifier in re.findall(r"%-?.", pattern.this):
        if specifier not in DATE_FORMAT_SPECIFIERS:
            return (
                f"calls date_format() with a specifier stook does not print as Trino does "
                f"(strftime's {specifier!r})"
            )
    return None


def _allowed(node: exp.Func) -> bool:
    from sqlglot import exp

    if isinstance(node, exp.Anonymous):
        return node.name.lower() in REWRITTEN_BY_NAME
    if isinstance(node, exp.Cast) and node.to.is_type(exp.DataType.Type.VARCHAR):
        # VARCHAR(n) truncates or raises in Trino: not reproduced.
        return not node.to.expressions
    return type(node).__name__ in SAME or type(node).__name__ in _REWRITES


def _function_name(node: exp.Expr) -> str:
    """The function's name as the query wrote it (Trino's spelling)."""
    from sqlglot import exp

    if isinstance(node, exp.Anonymous):
        return node.name.lower()
    text = node.sql(dialect="trino")
    return text.split("(", 1)[0].strip().lower() or type(node).__name__.lower()


# --- rewrites: each takes a node, returns what replaces it ---------------------------


def _call(name: str, *args: exp.Expr) -> exp.Expr:
    from sqlglot import exp

    return exp.Anonymous(this=name, expressions=list(args))


def _div(node: exp.Expr) -> exp.Expr:
    return _call("trino_divide", node.this, node.expression)


def _with_modifiers(node: exp.Expr) -> tuple[exp.Expr, Callable[[exp.Expr], exp.Expr]]:
    """The aggregate call `node` with its FILTER and OVER wrappers, and a function that
    rebuilds that chain around another aggregate of the same argument."""
    from sqlglot import exp

    outer = node
    while isinstance(outer.parent, (exp.Filter, exp.Window)) and outer.parent.this is outer:
        outer = outer.parent

    def around(aggregate: exp.Expr) -> exp.Expr:
        chain = outer.copy()
        inner = chain
        while inner.__class__ is not node.__class__:
            inner = inner.this
        inner.replace(aggregate)
        return chain if chain.__class__ is not node.__class__ else aggregate

    return outer, around


_Around = Callable[["exp.Expr"], "exp.Expr"]


def _aggregate_rewrite(node: exp.Expr, build: Callable[[_Around], exp.Expr]) -> exp.Expr:
    outer, around = _with_modifiers(node)
    if outer is not node:
        outer.replace(build(around))
        return node  # replaced higher up
    return build(around)


def _avg(node: exp.Expr) -> exp.Expr:
    from sqlglot import exp

    arg = node.this

    def build(around: Callable[[exp.Expr], exp.Expr]) -> exp.Expr:
        value = _distinct_free(arg)
        summed = _call("trino_avg_input", value.copy(), value.copy())
        if isinstance(arg, exp.Distinct):
            summed = exp.Distinct(expressions=[summed])
        total = around(exp.Sum(this=summed))
        count = around(exp.Count(this=arg.copy()))
        return _call("trino_avg", total, count)

    return _aggregate_rewrite(node, build)


def _sum(node: exp.Expr) -> exp.Expr:
    def build(around: Callable[[exp.Expr], exp.Expr]) -> exp.Expr:
        return _call("trino_sum", around(node.copy()))

    return _aggregate_rewrite(node, build)


def _round(node: exp.Expr) -> exp.Expr:
    x, digits = node.this, node.args.get("decimals")
    if digits is None:
        return _call("trino_round0", x)
    return _call("trino_round", x, digits)


def _distinct_free(arg: exp.Expr) -> exp.Expr:
    """x of an aggregate's argument DISTINCT x."""
    from sqlglot import exp

    if isinstance(arg, exp.Distinct) and arg.expressions:
        first: exp.Expr = arg.expressions[0]
        return first
    return arg


def _cast(node: exp.Cast) -> exp.Expr:
    from sqlglot import exp

    if node.to.is_type(exp.DataType.Type.VARCHAR):
        return _call("trino_varchar", node.this)
    if node.to.is_type(*exp.DataType.INTEGER_TYPES):
        node.set("this", _call("trino_integral", node.this))
    return node


def _bracket(node: exp.Bracket) -> exp.Expr:
    """x[i] (not element_at, whose NULL past the end is DuckDB's too) raises past the
    ends. sqlglot holds an index it knows to be an integer 0-based, any other as written:
    its own offset rule (the one its generator applies) gives the 1-based index."""
    from sqlglot import exp

    if node.args.get("safe") or len(node.expressions) != 1:
        return node
    (index,) = exp.apply_index_offset(
        node.this.copy(), [node.expressions[0].copy()], 1, dialect="duckdb"
    )
    return _call("trino_subscript", node.this.copy(), index, node.copy())


def _array_position(node: exp.Expr) -> exp.Expr:
    return _call("trino_array_position", node.this, node.expression)


def _dpipe(node: exp.Expr) -> exp.Expr:
    node.set("this", _call("trino_text", node.this))
    node.set("expression", _call("trino_text", node.expression))
    return node


def _concat(node: exp.Expr) -> exp.Expr:
    node.set("expressions", [_call("trino_text", e) for e in node.expressions])
    return node


def _array_call(name: str) -> Callable[[exp.Expr], exp.Expr]:
    def rewrite(node: exp.Expr) -> exp.Expr:
        args = [node.this] + ([node.expression] if node.expression is not None else [])
        return _call(name, *args)

    return rewrite


def _date_diff(node: exp.Expr) -> exp.Expr:
    """date_diff counts whole units elapsed (DuckDB's date_sub), not boundaries crossed."""
    from sqlglot import exp

    unit = exp.Literal.string(str(node.args["unit"].name if node.args.get("unit") else "day"))
    return _call("date_sub", unit, node.expression, node.this)


def _regexp_extract(node: exp.Expr) -> exp.Expr:
    from sqlglot import exp

    group = node.args.get("group") or exp.Literal.number(0)
    return _call("trino_regexp_extract", node.this, node.expression, group)


def _split_part(node: exp.Expr) -> exp.Expr:
    return _call("trino_split_part", node.this, node.args["delimiter"], node.args["part_index"])


def _substring(node: exp.Expr) -> exp.Expr:
    from sqlglot import exp

    length = node.args.get("length") or exp.Length(this=node.this.copy())
    return _call("trino_substr", node.this, node.args["start"], length)


def _trim(node: exp.Expr) -> exp.Expr:
    if node.expression is not None:  # trim(s, chars): DuckDB's is Trino's
        return node
    position = (node.args.get("position") or "BOTH").upper()
    name = {"LEADING": "trino_ltrim", "TRAILING": "trino_rtrim"}.get(position, "trino_trim")
    return _call(name, node.this)


def _width_bucket(node: exp.Expr) -> exp.Expr:
    return _call(
        "trino_width_bucket",
        node.this,
        node.args["min_value"],
        node.args["max_value"],
        node.args["num_buckets"],
    )


def _anonymous(node: exp.Expr) -> exp.Expr:
    from sqlglot import exp

    name = node.name.lower()
    if name not in REWRITTEN_BY_NAME:
        return node
    return exp.Anonymous(this=f"trino_{name}", expressions=node.expressions)


# By the class name of sqlglot's node.
_REWRITES: dict[str, Callable[[Any], exp.Expr]] = {
    "Div": _div,
    "Avg": _avg,
    "Sum": _sum,
    "Round": _round,
    "Cast": _cast,
    "TryCast": _cast,
    "RegexpExtract": _regexp_extract,
    "SplitPart": _split_part,
    "Substring": _substring,
    "Trim": _trim,
    "WidthBucket": _width_bucket,
    "Bracket": _bracket,
    "ArrayPosition": _array_position,
    "DateDiff": _date_diff,
    "DPipe": _dpipe,
    "Concat": _concat,
    "ArrayMax": _array_call("trino_array_max"),
    "ArrayMin": _array_call("trino_array_min"),
    "ArrayContains": _array_call("trino_contains"),
    "Anonymous": _anonymous,
}


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
