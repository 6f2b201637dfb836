"""The conformance corpus (trino_corpus.yml) through the real engine: no case where
stook gives a value different from Trino's; what it cannot reproduce it refuses, by
name. The docs' figure is this corpus's, checked here so that it cannot drift."""

from __future__ import annotations

import math
from collections import Counter
from decimal import ROUND_FLOOR, Decimal
from pathlib import Path
from typing import Any

import polars as pl
import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from stook.service.metrics_config import QueryError
from stook.service.metrics_config._query_engine import QueryEngine

CORPUS = Path(__file__).with_name("trino_corpus.yml")
DOCS = Path(__file__).parents[3] / "docs" / "metrics-config.md"
CASES: list[dict[str, Any]] = yaml.safe_load(CORPUS.read_text(encoding="utf-8"))
BEGIN, END = "<!-- conformance figure: begin -->", "<!-- conformance figure: end -->"


def _run(engine: QueryEngine, case: dict[str, Any]) -> tuple[str, Any]:
    """('value', v), ('error', message) or ('refused', message)."""
    query = case.get("query") or f"SELECT {case['sql']} AS v"
    try:
        result = engine.run("case", query)
    except QueryError as exc:
        message = str(exc).splitlines()[0]
        refused = "refused:" in message or "stook does not reproduce" in message
        return ("refused" if refused else "error"), message
    return "value", result.rows[0][0]


def _same(expected: Any, got: Any, approx: float | None) -> bool:
    if isinstance(expected, list):
        return (
            isinstance(got, list)
            and len(got) == len(expected)
            and all(_same(e, g, approx) for e, g in zip(expected, got, strict=True))
        )
    if isinstance(expected, float):
        if not isinstance(got, float):
            return False
        if math.isnan(expected):
            return math.isnan(got)
        if approx is not None:
            return math.isclose(got, expected, rel_tol=approx)
        return got == expected and math.copysign(1, got) == math.copysign(1, expected)
    if isinstance(expected, bool) or expected is None:
        return got is expected
    return type(got) is type(expected) and got == expected


def _outcome(engine: QueryEngine, case: dict[str, Any]) -> tuple[str, str]:
    """('agree' | 'refused' | 'differs', why)."""
    kind, got = _run(engine, case)
    if "refused" in case:
        named = str(case["refused"]).lower() in str(got).lower()
        return ("refused", "") if kind == "refused" and named else ("differs", f"{kind} {got!r}")
    if kind == "refused":
        return "refused", str(got)
    if "error" in case:
        return ("agree", "") if kind == "error" else ("differs", f"gave {got!r}, Trino raises")
    if kind == "error":
        return "differs", f"raised {got}"
    if "decimal" in case:
        ok = isinstance(got, Decimal) and str(got) == case["decimal"]
        return ("agree", "") if ok else ("differs", f"gave {got!r}, Trino {case['decimal']}")
    ok = _same(case["trino"], got, case.get("approx"))
    return ("agree", "") if ok else ("differs", f"gave {got!r}, Trino {case['trino']!r}")


@pytest.fixture(scope="module")
def outcomes() -> list[tuple[dict[str, Any], str, str]]:
    with QueryEngine({"t": pl.DataFrame({"x": [1]})}) as engine:
        return [(case, *_outcome(engine, case)) for case in CASES]


def test_no_case_differs_from_trino(outcomes: list[tuple[dict[str, Any], str, str]]) -> None:
    differs = [
        f"{case.get('sql') or case.get('query')}: {why}"
        for case, outcome, why in outcomes
        if outcome == "differs"
    ]
    assert differs == []


def test_a_case_refused_unexpectedly_is_marked_so(
    outcomes: list[tuple[dict[str, Any], str, str]],
) -> None:
    """A refusal is in the corpus as one (`refused:`), so the figure says what it is."""
    surprises = [
        f"{case.get('sql') or case.get('query')}: {why}"
        for case, outcome, why in outcomes
        if outcome == "refused" and "refused" not in case
    ]
    assert surprises == []


def _java_double_text(value: float) -> str:
    """Java's Double.toString, by its specification: of the decimals of the fewest
    digits n that read back as `value` (n = 1 or 2 when one digit does), the closest,
    ties to the even digit; in the scientific form of Trino's CAST(DOUBLE AS VARCHAR),
    trailing zeros dropped."""
    if math.isnan(value):
        return "NaN"
    if math.isinf(value):
        return "Infinity" if value > 0 else "-Infinity"
    if value == 0:
        return "-0E0" if math.copysign(1, value) < 0 else "0E0"
    exact = abs(Decimal(value))
    found: list[Decimal] = []
    for digits in range(1, 18):
        step = Decimal(1).scaleb(exact.adjusted() + 1 - digits)
        low = (exact / step).to_integral_value(ROUND_FLOOR) * step
        around = [low, low + step] + ([low.quantize(step / 10)] if digits == 1 else [])
        found = [d for d in around if float(d) == abs(value)]
        if digits == 1 and found:  # Java: the closest of one or two digits
            step = step / 10
            low = (exact / step).to_integral_value(ROUND_FLOOR) * step
            found += [d for d in (low, low + step) if float(d) == abs(value)]
        if found:
            break
    best = min(found, key=lambda d: (abs(d - exact), _last_digit_odd(d)))
    power = best.adjusted()
    mantissa = f"{best.scaleb(-power).normalize():f}"
    return f"{'-' if value < 0 else ''}{mantissa}E{power}"


def _last_digit_odd(number: Decimal) -> int:
    digits = number.as_tuple().digits
    return digits[-1] % 2 if digits else 0


@given(st.lists(st.floats(allow_nan=True, allow_infinity=True), min_size=1, max_size=50))
def test_a_double_as_varchar_is_javas_text(values: list[float]) -> None:
    with QueryEngine({"t": pl.DataFrame({"x": values}, schema={"x": pl.Float64})}) as engine:
        rows = engine.run("m", "SELECT x, CAST(x AS VARCHAR) FROM t").rows
    assert [text for _, text in rows] == [_java_double_text(v) for v, _ in rows]


def figure(outcomes: list[tuple[dict[str, Any], str, str]]) -> str:
    """The docs' table: per family, how many cases agree, are refused, differ."""
    counts: dict[str, Counter[str]] = {}
    for case, outcome, _ in outcomes:
        counts.setdefault(case["family"], Counter())[outcome] += 1
    lines = ["| Family | Cases | Agree | Refused | Differ |", "|---|---:|---:|---:|---:|"]
    total: Counter[str] = Counter()
    for family, count in counts.items():
        total.update(count)
        lines.append(
            f"| {family} | {sum(count.values())} | {count['agree']} | {count['refused']} "
            f"| {count['differs']} |"
        )
    lines.append(
        f"| **all** | {sum(total.values())} | {total['agree']} | {total['refused']} "
        f"| {total['differs']} |"
    )
    return "\n".join(lines)


def test_the_docs_show_this_corpus_figure(
    outcomes: list[tuple[dict[str, Any], str, str]],
) -> None:
    text = DOCS.read_text(encoding="utf-8")
    shown = text.split(BEGIN, 1)[1].split(END, 1)[0].strip()
    assert shown == figure(outcomes), "docs/metrics-config.md: paste this figure:\n" + figure(
        outcomes
    )


def _current_figure() -> str:
    with QueryEngine({"t": pl.DataFrame({"x": [1]})}) as engine:
        return figure([(case, *_outcome(engine, case)) for case in CASES])


if __name__ == "__main__":  # python -m tests.service.metrics_config.test_trino_conformance
    print(_current_figure())
