"""The plotly figures of a page: collected as JSON specs, drawn by one script at the end.

Figures are plain dicts (plotly.js's own JSON), not plotly.graph_objects: building a
figure object validates every property in Python, which costs more than the rest of a
preview for a long series, and the page needs only the JSON.
"""

from __future__ import annotations

import html
from dataclasses import dataclass, field
from typing import Any

from stook.service.preview._style import category_colors
from stook.service.preview._values import exact_text, number_text

_BASE_LAYOUT: dict[str, Any] = {
    "height": 320,
    "margin": {"l": 56, "r": 16, "t": 28, "b": 48},
    "font": {"size": 12, "family": "system-ui, sans-serif"},
    # Above the plot: below, a horizontal legend overlaps the x axis' title.
    "legend": {"orientation": "h", "x": 0, "xanchor": "left", "y": 1.02, "yanchor": "bottom"},
    "paper_bgcolor": "#fff",
    "plot_bgcolor": "#fff",
    "xaxis": {"automargin": True, "gridcolor": "#eceff1", "zeroline": False},
    "yaxis": {"automargin": True, "gridcolor": "#eceff1", "zeroline": False},
    "hovermode": "closest",
}


@dataclass
class Figures:
    """Every figure of the page, in order; `add` returns the element that shows one."""

    specs: list[dict[str, Any]] = field(default_factory=list)

    def add(
        self,
        data: list[dict[str, Any]],
        layout: dict[str, Any],
        *,
        metric: str,
        thinned: str | None = None,
    ) -> str:
        figure_id = f"figure-{len(self.specs)}"
        merged = {**_BASE_LAYOUT, **layout}
        for axis in ("xaxis", "yaxis"):
            merged[axis] = {**_BASE_LAYOUT[axis], **layout.get(axis, {})}
        if thinned:
            # Said on the chart itself, so a screenshot of it says so too.
            merged["annotations"] = [
                *layout.get("annotations", []),
                {
                    "text": thinned,
                    "xref": "paper",
                    "yref": "paper",
                    "x": 1,
                    "y": 1.02,
                    "xanchor": "right",
                    "yanchor": "bottom",
                    "showarrow": False,
                    "font": {"size": 10, "color": "#5f6368"},
                },
            ]
        self.specs.append({"id": figure_id, "data": data, "layout": merged})
        return f'<div class="plot" id="{figure_id}" data-metric="{html.escape(metric)}"></div>'

    def add_plotly(self, figure: dict[str, Any], *, metric: str) -> str:
        """A PLOTLY metric's own figure, as written, in the page's frame where it sets
        none of its own (height, margins, axes that make room for their labels), and
        slices or bars named for statuses in those statuses' colours where it gives none."""
        figure_id = f"figure-{len(self.specs)}"
        layout = dict(figure.get("layout") or {})
        if isinstance(layout.get("title"), str):
            # plotly.py and older plotly.js took a bare string; plotly.js 3 wants {text}.
            layout["title"] = {"text": layout["title"]}
        for key in ("height", "margin", "font", "paper_bgcolor", "plot_bgcolor"):
            layout.setdefault(key, _BASE_LAYOUT[key])
        if "title" in layout and "margin" not in (figure.get("layout") or {}):
            layout["margin"] = {**_BASE_LAYOUT["margin"], "t": 48}
        for axis in ("xaxis", "yaxis"):
            if isinstance(layout.get(axis, {}), dict):
                layout[axis] = {"automargin": True, **layout.get(axis, {})}
        data = [_status_colored(trace) for trace in figure.get("data") or []]
        self.specs.append({"id": figure_id, "data": data, "layout": layout})
        return f'<div class="plot" id="{figure_id}" data-metric="{html.escape(metric)}"></div>'


def _status_colored(trace: Any) -> Any:
    """A pie's slices or a bar trace's bars in status colours when every label names a
    status and the trace sets no colours of its own."""
    if not isinstance(trace, dict):
        return trace
    marker = trace.get("marker")
    if isinstance(marker, dict) and ("colors" in marker or "color" in marker):
        return trace
    kind = trace.get("type")
    labels = trace.get("labels") if kind == "pie" else trace.get("x") if kind == "bar" else None
    colors = category_colors(labels) if isinstance(labels, list) else None
    if colors is None:
        return trace
    key = "colors" if kind == "pie" else "color"
    return {**trace, "marker": {**(marker or {}), key: colors}}


def bound_lines(
    above: float | None, below: float | None
) -> tuple[list[dict[str, Any]], list[dict[str, Any]]]:
    """Dashed lines (and their labels) at a failure definition's bounds, in ink: a bound is
    not a status, and the points beyond it say theirs in their own colours."""
    shapes: list[dict[str, Any]] = []
    labels: list[dict[str, Any]] = []
    color = "#5f6368"
    for value, words in ((above, "fails above"), (below, "fails below")):
        if value is None:
            continue
        shapes.append(
            {
                "type": "line",
                "xref": "paper",
                "x0": 0,
                "x1": 1,
                "y0": value,
                "y1": value,
                "line": {"color": color, "dash": "dash", "width": 1},
            }
        )
        labels.append(
            {
                "text": f"{words} {number_text(value)}",
                "hovertext": f"{words} {exact_text(value)}",
                "xref": "paper",
                "x": 0,
                "xanchor": "left",
                "y": value,
                "yanchor": "bottom",
                "showarrow": False,
                "font": {"size": 10, "color": color},
            }
        )
    return shapes, labels
