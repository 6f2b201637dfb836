"""Seeded fuzz of config files: whatever a file holds, reading it ends with a config or
with problems, each one line naming the file -- never an exception or a traceback."""

from __future__ import annotations

import copy
from pathlib import Path
from typing import Any

import pytest
import yaml
from hypothesis import given
from hypothesis import strategies as st

from stook.service.metrics_config import read_config
from tests.hypothesis_profiles import examples

BASE: dict[str, Any] = {
    "version": 1,
    "global": {"skip-if-no-data": False},
    "topics": {
        "speed": {"schema": {"lane": "string", "speed": "float"}},
        "lane_event": {
            "event": True,
            "schema": {"name": "string", "description": "string", "status": "status"},
        },
    },
    "metrics": {
        "Max speed": {
            "type": "test",
            "description": "Fastest",
            "query_string": "SELECT MAX(speed) AS value FROM speed",
            "template_type": "system",
            "template": "scalar",
            "units": "m/s",
            "skip_if_no_data": True,
            "status": {"query_string": "SELECT 1 FROM speed WHERE speed > ?", "block": 20},
        },
        "Speeds": {
            "type": "batch",
            "query_string": "SELECT lane, speed FROM speed",
            "template": "histogram",
            "template_settings": {"display": {"bins": 10}, "xaxis": {"label": "m/s"}},
        },
        "Figure": {
            "type": "dashboard",
            "query_string": "SELECT speed FROM speed",
            "template_type": "custom",
            "template_file": "figure.liquid",
        },
    },
    "metrics sets": {"core": {"metrics": ["Max speed", "Speeds"]}},
    "dashboards": {"Trends": {"metrics_set": "core", "refresh": "auto", "day_range": 30}},
}

# Values a hand-edited config may hold where another was meant.
VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(2**70), 2**70)
    | st.floats(allow_nan=True)
    | st.text(max_size=20)
    | st.sampled_from(["report", "auto", "sometimes", "sub/x.liquid", "SELECT (", "?"]),
    lambda inner: st.lists(inner, max_size=3) | st.dictionaries(st.text(max_size=8), inner),
    max_leaves=8,
)


def _paths(doc: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every key path of `doc`'s mappings."""
    found = []
    if isinstance(doc, dict):
        for key, value in doc.items():
            found.append((*prefix, key))
            found.extend(_paths(value, (*prefix, key)))
    return found


@st.composite
def mutated(draw: st.DrawFn) -> dict[str, Any]:
    doc = copy.deepcopy(BASE)
    for _ in range(draw(st.integers(1, 4))):
        paths = _paths(doc)
        if not paths:
            break
        path = draw(st.sampled_from(paths))
        parent = doc
        for key in path[:-1]:
            parent = parent[key]
        action = draw(st.sampled_from(["replace", "delete", "add"]))
        if action == "replace":
            parent[path[-1]] = draw(VALUES)
        elif action == "delete":
            del parent[path[-1]]
        else:
            parent[draw(st.text(min_size=1, max_size=12))] = draw(VALUES)
    return doc


def _check_lines(path: Path) -> None:
    config, problems = read_config([path])
    for line in [*problems, *config.warnings]:
        assert line.startswith(str(path)), line
        assert "\n" not in line


@given(doc=mutated())
@examples(200)
def test_a_mutated_config_is_read_or_refused_line_by_line(
    tmp_path_factory: pytest.TempPathFactory, doc: Any
) -> None:
    tmp_path = tmp_path_factory.mktemp("config")
    (tmp_path / "templates").mkdir()
    (tmp_path / "templates" / "figure.liquid").write_text("{}", encoding="utf-8")
    path = tmp_path / "config.resim.yml"
    path.write_text(yaml.safe_dump(doc, allow_unicode=True), encoding="utf-8")
    _check_lines(path)


@given(data=st.binary(max_size=300) | st.text(max_size=300).map(str.encode))
@examples(200)
def test_any_bytes_are_read_or_refused_line_by_line(
    tmp_path_factory: pytest.TempPathFactory, data: bytes
) -> None:
    path = tmp_path_factory.mktemp("config") / "config.resim.yml"
    path.write_bytes(data)
    _check_lines(path)


@given(doc=mutated())
@examples(40)
def test_check_of_a_mutated_config_is_exit_0_or_2(
    tmp_path_factory: pytest.TempPathFactory, doc: Any
) -> None:
    import contextlib
    import io

    from stook.service.cli._main import run_cli

    tmp_path = tmp_path_factory.mktemp("config")
    (tmp_path / "templates").mkdir()
    (tmp_path / "templates" / "figure.liquid").write_text("{}", encoding="utf-8")
    path = tmp_path / "config.resim.yml"
    path.write_text(yaml.safe_dump(doc, allow_unicode=True), encoding="utf-8")
    err = io.StringIO()
    with contextlib.redirect_stderr(err), contextlib.redirect_stdout(io.StringIO()):
        code = run_cli(["metrics-config", "check", str(path)])
    assert code in (0, 2)
    assert "Traceback" not in err.getvalue()
    for line in err.getvalue().splitlines():
        assert line.removeprefix("warning: ").startswith(str(path)), line
