"""Bad configs, bad rows, failing queries and templates: one clear error each, exit 2 or
4, no output file, no traceback."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

import pytest

from stook.service.cli._main import run_cli
from stook.testing.metrics_config_fixture import FIXTURE_CONFIG_YAML
from tests.service.metrics_config.emitted import JobData


@pytest.fixture(autouse=True)
def _console_errors(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STOOK_LOG_FORMAT", "console")


def _config(tmp_path: Path, text: str, name: str = "config.resim.yml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def _stderr(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return err


BROKEN = """\
version: 1
topics:
  speed:
    schema: {speed: float, mood: feelings, Speed: int, timestamp: int}
  Metadata:
    schema: {x: int}
metrics:
  A:
    type: test
    query_string: SELECT speed FROM speed
    template: sparkline
  B:
    type: weekly
    query_string: SELECT speed FROM speed
    template: scalar
  C:
    type: test
    query_string: SELECT MAX(speed) FROM speed
    template: scalar
    status: {query_string: SELECT 1 FROM speed, block: 3}
  D:
    type: test
    template_type: custom
    template_file: missing.liquid
    query_string: SELECT speed FROM speed
  E:
    type: test
    query_string: SELEC speed FROM
    template: table
  F:
    type: test
    query_string: DROP TABLE speed
    template: table
metrics sets:
  core: {metrics: [A, Z]}
"""


def test_check_prints_one_line_per_problem(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = _config(tmp_path, BROKEN)
    assert run_cli(["metrics-config", "check", str(config)]) == 2
    lines = _stderr(capsys).splitlines()
    expected = [
        "column 'mood' has unknown type 'feelings'",
        "column 'Speed' is named twice (SQL ignores case)",
        "column 'timestamp' is one every topic table adds",
        "topics 'Metadata': the name is taken by the metadata table (SQL ignores case)",
        "metrics 'A': 'template' must be one of",
        "metrics 'B': 'type' must be one of test, batch, dashboard, not 'weekly'",
        "metrics 'C': the status query_string must have exactly 1 '?'",
        "metrics 'E': query_string does not parse: Invalid expression / Unexpected token "
        "(line 1, column 16)",
        "metrics 'F': query_string does not parse: must be a query (SELECT ...), not DROP",
        "metrics sets 'core': names metric 'Z', which the config lacks",
        "metrics 'D': template",
    ]
    assert len(lines) == len(expected)
    for line, part in zip(lines, expected, strict=True):
        assert str(config) in line
        assert part in line


def test_check_binds_queries_against_the_topics(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = FIXTURE_CONFIG_YAML.replace(
        'SELECT MAX(speed) AS "Max speed" FROM speed', "SELECT MAX(velocity) FROM speed"
    )
    config = _config(tmp_path, text)
    (tmp_path / "templates").mkdir()
    (tmp_path / "templates" / "speed_figure.liquid").write_text("{}", encoding="utf-8")
    assert run_cli(["metrics-config", "check", str(config)]) == 2
    (line,) = _stderr(capsys).splitlines()
    assert "metrics 'Max speed': query_string does not run" in line
    assert "velocity" in line


@pytest.mark.parametrize(
    ("second", "problem", "theirs"),
    [
        (
            "version: 1\ntopics:\n  speed: {schema: {x: int}}\n",
            "topics name 'speed' is also",
            "duplicate topic name",
        ),
        ("version: 2\n", "version 2 conflicts with version 1", "conflicting versions"),
        ("topics: {}\n", "'version' is required", "version is required"),
    ],
)
def test_merging_follows_the_platform(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], second: str, problem: str, theirs: str
) -> None:
    from resim.sdk.metrics.emissions import merge_metrics_config_files

    first = _config(tmp_path, "version: 1\ntopics:\n  speed: {schema: {x: float}}\n", "a.yml")
    other = _config(tmp_path, second, "b.yml")
    with pytest.raises(ValueError, match=theirs):  # ReSim refuses the pair too
        merge_metrics_config_files([first, other])
    assert run_cli(["metrics-config", "check", str(first), str(other)]) == 2
    (line,) = _stderr(capsys).splitlines()
    assert problem in line
    assert str(other) in line


def test_configs_resim_accepts_merge_to_the_same_topics(tmp_path: Path) -> None:
    from resim.sdk.metrics.emissions import merge_metrics_config_files

    from stook.service.metrics_config import load_config

    a = _config(tmp_path, "version: 1\ntopics:\n  speed: {schema: {x: float}}\nx: 1\n", "a.yml")
    b = _config(tmp_path, "version: 1\ntopics:\n  lane: {event: true, schema: {n: int}}\n", "b.yml")
    theirs = merge_metrics_config_files([a, b])
    ours = load_config([a, b])
    assert {
        n: {"schema": dict(t.schema), **({"event": True} if t.event else {})}
        for n, t in ours.topics.items()
    } == theirs["topics"]


def _eval(config: Path, emissions: Path, out: Path, level: str = "test", *extra: str) -> int:
    return run_cli(
        [
            "metrics-config",
            "eval",
            str(config),
            "--emissions",
            str(emissions),
            "--level",
            level,
            "--outputs",
            str(out),
            *extra,
        ]
    )


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        (
            {
                "$metadata": {"topic": "detections"},
                "$data": {"label": "car", "count": True, "confident": True},
            },
            "topic 'detections', column 'count': expected int, got a boolean",
        ),
        (
            {"$metadata": {"topic": "detections"}, "$data": {"label": "car", "confident": True}},
            "topic 'detections', column 'count': missing",
        ),
        (
            {"$metadata": {"topic": "speed"}, "$data": {"lane": "a", "speed": None}},
            "topic 'speed', column 'speed': null is not a float",
        ),
        (
            {"$metadata": {"topic": "speed"}, "$data": {"lane": "a", "speed": 1, "extra": 2}},
            "topic 'speed', column 'extra': not in the topic's schema",
        ),
        (
            {"$metadata": {"topic": "weather"}, "$data": {}},
            "topic 'weather' is not in the config",
        ),
        ("{not json", "not a JSON object"),
        (
            '{"$metadata": {"topic": "detections"}, '
            '"$data": {"label": "car", "count": 18446744073709551615, "confident": true}}',
            "topic 'detections', column 'count': the value does not fit a int (64 bits)",
        ),
    ],
)
def test_a_bad_row_names_file_line_topic_and_column(
    tmp_path: Path,
    config: Path,
    one_job: tuple[Path, JobData],
    capsys: pytest.CaptureFixture[str],
    line: object,
    problem: str,
) -> None:
    emissions, _ = one_job
    rows = emissions.read_text(encoding="utf-8").splitlines()
    rows.insert(3, line if isinstance(line, str) else json.dumps(line))
    emissions.write_text("\n".join(rows) + "\n", encoding="utf-8")
    out = tmp_path / "out"
    assert _eval(config, emissions, out) == 4
    err = _stderr(capsys)
    assert f"{emissions} line 4: {problem}" in err
    assert not (out / "metrics.binproto").exists()


def test_strict_a_failing_query_names_the_metric_its_sql_and_the_engine(
    tmp_path: Path, one_job: tuple[Path, JobData], capsys: pytest.CaptureFixture[str]
) -> None:
    emissions, _ = one_job
    text = FIXTURE_CONFIG_YAML.replace(
        'SELECT MAX(speed) AS "Max speed" FROM speed',
        "SELECT MAX(CAST(lane AS INTEGER)) FROM speed",
    )
    config = _config(tmp_path, text)
    (tmp_path / "templates").mkdir()
    (tmp_path / "templates" / "speed_figure.liquid").write_text("{}", encoding="utf-8")
    out = tmp_path / "out"
    assert _eval(config, emissions, out, "test", "--strict") == 4
    err = _stderr(capsys)
    assert "metric 'Max speed': its query failed" in err
    assert "SELECT MAX(CAST(lane AS INTEGER)) FROM speed" in err
    assert "Conversion Error" in err
    assert not out.exists()


def test_strict_a_template_that_prints_no_json_is_exit_4(
    tmp_path: Path, config: Path, one_job: tuple[Path, JobData], capsys: pytest.CaptureFixture[str]
) -> None:
    emissions, _ = one_job
    (config.parent / "templates" / "speed_figure.liquid").write_text(
        '{"data": [{{ t | first }},]}', encoding="utf-8"
    )
    out = tmp_path / "out"
    assert _eval(config, emissions, out, "test", "--strict") == 4
    err = _stderr(capsys)
    assert "metric 'Speed figure': template 'speed_figure.liquid': did not print JSON" in err
    assert not out.exists()


def test_an_unknown_metrics_set_is_exit_2(
    tmp_path: Path, config: Path, one_job: tuple[Path, JobData], capsys: pytest.CaptureFixture[str]
) -> None:
    emissions, _ = one_job
    code = run_cli(
        [
            "metrics-config",
            "eval",
            str(config),
            "--emissions",
            str(emissions),
            "--level",
            "test",
            "--outputs",
            str(tmp_path / "out"),
            "--metrics-set",
            "nope",
        ]
    )
    assert code == 2
    assert "unknown metrics set 'nope' (known: core, overview)" in _stderr(capsys)


def test_bytes_that_are_not_utf8_are_exit_4(
    tmp_path: Path, config: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    emissions = tmp_path / "emissions.resim.jsonl"
    emissions.write_bytes(b'{"$metadata": {"topic": "camera"}, "$data": {"frame": "\xe9"}}\n')
    out = tmp_path / "out"
    assert _eval(config, emissions, out) == 4
    assert f"{emissions} line 1: not UTF-8 (byte 56 of the line)" in _stderr(capsys)
    assert not out.exists()


def test_strict_an_image_whose_file_is_missing_is_exit_4(
    tmp_path: Path, config: Path, one_job: tuple[Path, JobData], capsys: pytest.CaptureFixture[str]
) -> None:
    emissions, job = one_job
    (emissions.parent / job.frame).unlink()
    out = tmp_path / "out"
    assert _eval(config, emissions, out, "test", "--strict") == 4
    assert f"attached file {job.frame!r} is in no job's folder" in _stderr(capsys)
    assert not out.exists()


def test_check_parses_the_templates(config: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (config.parent / "templates" / "speed_figure.liquid").write_text(
        "{% for x in t %}{{ x }}", encoding="utf-8"
    )
    assert run_cli(["metrics-config", "check", str(config)]) == 2
    (line,) = _stderr(capsys).splitlines()
    assert "metrics 'Speed figure': template 'speed_figure.liquid' does not parse" in line


@pytest.mark.parametrize(
    ("make", "problem"),
    [
        (lambda root: root / "nowhere.jsonl", "no such file or folder"),
        (lambda root: root, "no job folder in it holds emissions.resim.jsonl"),
    ],
)
def test_a_bad_emissions_path_is_exit_2(
    tmp_path: Path,
    config: Path,
    capsys: pytest.CaptureFixture[str],
    make: Callable[[Path], Path],
    problem: str,
) -> None:
    empty = tmp_path / "empty"
    empty.mkdir()
    path = make(empty)
    assert _eval(config, path, tmp_path / "out", "batch") == 2
    assert f"{path}: {problem}" in _stderr(capsys)


def test_a_bad_job_json_is_exit_2(
    tmp_path: Path, config: Path, one_job: tuple[Path, JobData], capsys: pytest.CaptureFixture[str]
) -> None:
    emissions, _ = one_job
    batch = tmp_path / "batch"
    (batch / "job-a").mkdir(parents=True)
    (batch / "job-a" / "emissions.resim.jsonl").write_bytes(emissions.read_bytes())
    (batch / "job-a" / "job.json").write_text('{"job_id": "a", "colour": "red"}')
    assert _eval(config, batch, tmp_path / "out", "batch") == 2
    assert "unknown key(s) 'colour'" in _stderr(capsys)
