"""Custom templates: Liquid that prints a Plotly figure's JSON (python-liquid).

The query's columns arrive as arrays named by their aliases; a `json` filter prints a
value as JSON, as the platform's templates expect.
"""

from __future__ import annotations

import json
from typing import Any

from stook.service.metrics_config._errors import TemplateError
from stook.service.metrics_config._model import Metric
from stook.service.metrics_config._query_engine import Result
from stook.service.metrics_config._values import plain


def _json_filter(value: Any) -> str:
    return json.dumps(plain(value))


def _environment() -> Any:
    from liquid import Environment

    env = Environment()
    env.filters["json"] = _json_filter
    return env


def template_problem(name: str, text: str) -> str | None:
    """Why the Liquid template does not parse (None: it does)."""
    from liquid.exceptions import LiquidError

    try:
        _environment().from_string(text)
    except LiquidError as exc:
        return f"template {name!r} does not parse: {' '.join(str(exc).split())}"
    return None


def render_figure(metric: Metric, text: str, result: Result) -> dict[str, Any]:
    """The figure the template prints for `result`; TemplateError names the template."""
    from liquid.exceptions import LiquidError

    env = _environment()
    columns = {name: [plain(v) for v in result.column(i)] for i, name in enumerate(result.columns)}
    where = f"metric {metric.name!r}: template {metric.template_file!r}"
    try:
        printed = env.from_string(text).render(**columns)
    except LiquidError as exc:
        raise TemplateError(f"{where}: {' '.join(str(exc).split())}") from None
    try:
        figure = json.loads(printed)
    except ValueError as exc:
        shown = " ".join(printed.split())[:120]
        raise TemplateError(f"{where}: did not print JSON ({exc}): {shown!r}") from None
    if not isinstance(figure, dict):
        raise TemplateError(f"{where}: printed {type(figure).__name__}, not a Plotly figure object")
    return figure
