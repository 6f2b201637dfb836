"""The platform's status colours and the page's one style sheet."""

from __future__ import annotations

from collections.abc import Sequence

# The colours ReSim's dashboard gives each status (and an unset one).
STATUS_COLORS: dict[str, str] = {
    "PASSED": "#1e8e3e",
    "FAIL_WARN": "#e37400",
    "FAIL_BLOCK": "#d93025",
    "NOT_APPLICABLE": "#80868b",
    "RAW": "#1a73e8",
    "NO_STATUS": "#bdc1c6",
}
UNKNOWN_STATUS_COLOR = "#9334e6"
ERROR_COLOR = "#a50e0e"
"""A metric that could not be computed (a config metric's failed query or template)."""

# Traces without a status of their own: no green, orange or red, which say a status.
PALETTE = ["#1a73e8", "#12b5cb", "#f538a0", "#3949ab", "#8d6e63", "#9e9d24", "#546e7a"]


# A bar, slice or point named for a status (a job's conflated status, a metric's status)
# takes that status's colour, whatever the status of the metric that draws it: a PASSED
# bar is green in a chart that fails. Job statuses without a metric status of their own
# get the neutral colours the platform's job list uses.
_CATEGORY_COLORS: dict[str, str] = {
    **STATUS_COLORS,
    "NO_STATUS_REPORTED": STATUS_COLORS["NO_STATUS"],
    "WARNING": STATUS_COLORS["FAIL_WARN"],
    "BLOCKER": STATUS_COLORS["FAIL_BLOCK"],
    "ERROR": "#7b1fa2",
    "CANCELLED": "#80868b",
    "QUEUED": "#bdc1c6",
    "RUNNING": "#1a73e8",
}


def status_color(name: str) -> str:
    return STATUS_COLORS.get(name, UNKNOWN_STATUS_COLOR)


def category_colors(labels: Sequence[object]) -> list[str] | None:
    """The status colour of each label when every label names a status ("PASSED",
    "Blocker", "fail warn"), else None: a chart of experiences keeps its own colours."""
    colors = [
        _CATEGORY_COLORS.get(str(label).strip().upper().replace(" ", "_")) for label in labels
    ]
    if not colors or any(c is None for c in colors):
        return None
    return [c for c in colors if c is not None]


CSS = """
:root { --ink: #202124; --muted: #5f6368; --line: #dadce0; --card: #fff; --page: #f1f3f4; }
* { box-sizing: border-box; }
body { margin: 0; background: var(--page); color: var(--ink);
  font: 14px/1.45 system-ui, -apple-system, "Segoe UI", Roboto, sans-serif; }
header.page { padding: 12px 16px; background: #fff; border-bottom: 1px solid var(--line); }
header.page h1 { margin: 0; font-size: 18px; }
header.page p { margin: 2px 0 0; color: var(--muted); font-size: 12px; }
.grid { display: grid; gap: 12px; padding: 12px; align-items: stretch;
  grid-template-columns: repeat(var(--columns), minmax(320px, 1fr)); overflow-x: auto; }
.grid.single { grid-template-columns: repeat(auto-fill, minmax(min(100%, 380px), 1fr));
  align-items: start; }
.grid.single > .file, .grid.single > .events, .grid.single > .data { grid-column: 1 / -1; }
.section { grid-column: 1 / -1; margin: 8px 0 -4px; font-size: 15px; color: var(--muted); }
.card { background: var(--card); border: 1px solid var(--line); border-radius: 8px;
  padding: 12px 14px; min-width: 0; break-inside: avoid; page-break-inside: avoid; }
.card.failed { border-color: #d93025; }
details.tag { display: inline-block; }
details.tag code { display: block; white-space: pre-wrap; overflow-wrap: anywhere; }
.card.absent { background: transparent; border-style: dashed; color: var(--muted); }
.card h2 { margin: 0; font-size: 15px; word-break: break-word; }
.card h3 { margin: 0 0 4px; font-size: 16px; word-break: break-all; }
.meta { display: flex; flex-wrap: wrap; gap: 4px 8px; align-items: center; margin: 4px 0;
  color: var(--muted); font-size: 12px; }
.chip { display: inline-block; padding: 1px 8px; border-radius: 10px; color: #fff;
  font-size: 11px; font-weight: 600; letter-spacing: .02em; white-space: nowrap;
  -webkit-print-color-adjust: exact; print-color-adjust: exact; }
.tag { background: #e8eaed; border-radius: 4px; padding: 0 6px; color: var(--ink); }
.blocking { color: #d93025; font-weight: 600; }
.desc { margin: 4px 0 8px; color: var(--muted); }
.scalar { font-size: 28px; font-weight: 600; margin: 6px 0; }
.scalar .unit { font-size: 16px; color: var(--muted); margin-left: 4px; }
.note { font-size: 12px; color: var(--muted); margin: 4px 0; }
.plot { width: 100%; min-height: 300px; }
.placeholder { border: 1px dashed var(--line); border-radius: 6px; padding: 16px;
  color: var(--muted); text-align: center; background: #fafafa; }
table { border-collapse: collapse; width: 100%; font-size: 13px; margin: 4px 0; }
th, td { border-bottom: 1px solid var(--line); padding: 3px 6px; text-align: left;
  vertical-align: top; }
td.num { text-align: right; font-variant-numeric: tabular-nums; }
.text { overflow-wrap: anywhere; overflow-x: auto; }
/* A wide table scrolls rather than break its headers inside a word ("Sprea d"). */
.text th, .text td { overflow-wrap: normal; }
.text th { white-space: nowrap; }
details.desc { margin: 4px 0 8px; color: var(--muted); }
details.desc summary { font-size: 14px; }
details.desc p { margin: 4px 0 0; }
.text pre { overflow-x: auto; background: #f8f9fa; padding: 8px; }
.images { display: flex; flex-wrap: wrap; gap: 8px; }
.images figure { margin: 0; flex: 1 1 200px; max-width: 100%; }
.images img { max-width: 100%; height: auto; border: 1px solid var(--line); display: block; }
.images figcaption { font-size: 12px; color: var(--muted); }
.problems { color: #a50e0e; margin: 4px 0 0; padding-left: 18px; font-size: 12px; }
.ok { color: #137333; }
details summary { cursor: pointer; color: var(--muted); font-size: 12px; }
@media (max-width: 700px) {
  .grid { padding: 6px; gap: 8px; }
  .scalar { font-size: 22px; }
}
@media print {
  body { background: #fff; }
  .grid { overflow: visible; padding: 0; grid-template-columns: repeat(var(--columns), 1fr); }
  .grid.single { grid-template-columns: 1fr 1fr; }
  .card { border-color: #999; }
  details { display: block; }
  .modebar-container { display: none !important; }
}
"""
