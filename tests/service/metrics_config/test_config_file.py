"""The config file as ReSim's CLI reads it: its keys, `global:` settings, the older
`type: report`, dashboards, templates, versions and merging -- and `check` showing every
problem at once."""

from __future__ import annotations

from pathlib import Path

import pytest

from stook.service.cli._main import run_cli
from stook.service.metrics_config import MetricsConfigError, load_config, read_config

HEAD = """\
version: 1
topics:
  speed: {schema: {speed: float}}
"""

GOOD_METRIC = """\
  Max speed:
    type: test
    query_string: SELECT MAX(speed) AS value FROM speed
    template: scalar
"""


@pytest.fixture(autouse=True)
def _console_errors(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STOOK_LOG_FORMAT", "console")


def _write(folder: Path, text: str, name: str = "config.resim.yml") -> Path:
    path = folder / name
    path.write_text(text, encoding="utf-8")
    return path


def _check(capsys: pytest.CaptureFixture[str], *args: str | Path) -> tuple[int, list[str]]:
    code = run_cli(["metrics-config", "check", *map(str, args)])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, err.splitlines()


@pytest.mark.parametrize(
    ("metric_lines", "unknown", "suggestion"),
    [
        ("    units: m/s\n    unit: m/s\n", "unit", "units"),
        ("    skip_if_nodata: true\n", "skip_if_nodata", "skip_if_no_data"),
        ("    desciption: Fastest\n", "desciption", "description"),
        ("    status: {query_string: SELECT 1 WHERE 1 > ?, blok: 3, warn: 2}\n", "blok", "block"),
    ],
)
def test_an_unknown_key_is_named_with_a_suggestion(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    metric_lines: str,
    unknown: str,
    suggestion: str,
) -> None:
    config = _write(tmp_path, HEAD + "metrics:\n" + GOOD_METRIC + metric_lines)
    code, lines = _check(capsys, config)
    assert code == 0  # a warning: the platform's CLI drops the key without a word
    (warning,) = [line for line in lines if line.startswith("warning: ")]
    assert f"{config}: metrics 'Max speed'" in warning
    assert f"unknown key {unknown!r} (did you mean {suggestion!r}?)" in warning

    code, lines = _check(capsys, "--strict", config)
    assert code == 2
    (error,) = lines
    assert f"unknown key {unknown!r} (did you mean {suggestion!r}?)" in error
    assert not error.startswith("warning: ")


def test_unknown_keys_of_every_part_are_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = f"""\
version: 1
global: {{skip_if_no_data: true}}
topics:
  speed: {{schema: {{speed: float}}, events: true}}
metrics:
{GOOD_METRIC}
metric sets:
  core: {{metrics: [Max speed]}}
metrics sets:
  main: {{metrics: [Max speed], metric: [Max speed]}}
dashboards:
  Trends: {{metrics_set: main, refesh: auto}}
"""
    config = _write(tmp_path, text)
    code, lines = _check(capsys, config)
    assert code == 0
    expected = [
        "unknown key 'metric sets' (did you mean 'metrics sets'?)",
        "global: unknown key 'skip_if_no_data' (did you mean 'skip-if-no-data'?)",
        "topics 'speed': unknown key 'events' (did you mean 'event'?)",
        "metrics sets 'main': unknown key 'metric' (did you mean 'metrics'?)",
        "dashboards 'Trends': unknown key 'refesh' (did you mean 'refresh'?)",
    ]
    warnings = [line for line in lines if line.startswith("warning: ")]
    assert len(warnings) == len(expected)
    for line, part in zip(warnings, expected, strict=True):
        assert line.startswith(f"warning: {config}: ")
        assert part in line


def test_eval_says_an_unknown_key_and_still_evaluates(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = _write(tmp_path, HEAD + "metrics:\n" + GOOD_METRIC + "    unit: m/s\n")
    emissions = _write(
        tmp_path, '{"$metadata": {"topic": "speed"}, "$data": {"speed": 2.5}}\n', "e.jsonl"
    )
    out = tmp_path / "out"
    args = ["eval", str(config), "--emissions", str(emissions), "--level", "test"]
    assert run_cli(["metrics-config", *args, "--outputs", str(out)]) == 0
    err = capsys.readouterr().err
    assert err.count("unknown key 'unit' (did you mean 'units'?)") == 1
    assert (out / "metrics.binproto").is_file()


def test_a_misspelt_template_key_is_named(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = HEAD + "metrics:\n  A:\n    type: test\n    query_string: SELECT 1\n"
    text += "    templte: scalar\n"
    config = _write(tmp_path, text)
    code, lines = _check(capsys, config)
    assert code == 2
    assert lines == [
        f"warning: {config}: metrics 'A': unknown key 'templte' (did you mean 'template'?)",
        f"{config}: metrics 'A': 'template' is required (line, bar, table, scalar, image, "
        "state_timeline, histogram, pie, artifact, video)",
    ]


def test_check_shows_every_problem_not_the_first(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    text = f"""\
{HEAD}metrics:
{GOOD_METRIC}  Bad key:
    type: test
    query_string: SELECT MAX(speed) AS value FROM speed
    template: scalar
    skip_if_no_data: sometimes
  Unknown column:
    type: test
    query_string: SELECT MAX(velocity) AS value FROM speed
    template: scalar
  Bad SQL:
    type: test
    query_string: SELEC speed FROM
    template: table
"""
    config = _write(tmp_path, text)
    code, lines = _check(capsys, config)
    assert code == 2
    assert len(lines) == 3
    assert "metrics 'Bad key': 'skip_if_no_data' must be true or false" in lines[0]
    assert "metrics 'Bad SQL': query_string does not parse" in lines[1]
    assert "metrics 'Unknown column': query_string does not run" in lines[2]
    assert "velocity" in lines[2]


def test_global_skip_applies_to_its_own_file_and_yields_to_the_metric(tmp_path: Path) -> None:
    first = _write(
        tmp_path,
        f"""\
{HEAD}global:
  skip-if-no-data: true
metrics:
  Inherits:
    type: test
    query_string: SELECT 1
    template: scalar
  Own setting:
    type: test
    query_string: SELECT 1
    template: scalar
    skip_if_no_data: false
  CLI spelling:
    type: test
    query_string: SELECT 1
    template: scalar
    skip-if-no-data: false
""",
        "a.yml",
    )
    second = _write(
        tmp_path,
        "version: 1\nmetrics:\n  Other file:\n    type: test\n    query_string: SELECT 1\n"
        "    template: scalar\n",
        "b.yml",
    )
    config = load_config([first, second])
    skips = {name: metric.skip_if_no_data for name, metric in config.metrics.items()}
    assert skips == {
        "Inherits": True,
        "Own setting": False,
        "CLI spelling": False,
        "Other file": False,
    }


def test_the_two_spellings_of_skip_must_agree(tmp_path: Path) -> None:
    text = f"{HEAD}metrics:\n{GOOD_METRIC}    skip_if_no_data: true\n    skip-if-no-data: false\n"
    disagree = "'skip_if_no_data' and 'skip-if-no-data' disagree"
    with pytest.raises(MetricsConfigError, match=disagree):
        load_config([_write(tmp_path, text)])


def test_type_report_is_read_as_dashboard_with_a_notice(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # As in isaacsim-demo: the topics in one file, the report's metrics in another.
    config = _write(tmp_path, HEAD + "metrics:\n" + GOOD_METRIC, "config.resim.yml")
    report = _write(
        tmp_path,
        "version: 1\ntopics: {}\nmetrics:\n  Trend:\n    type: report\n"
        "    query_string: SELECT build_version, MAX(speed) FROM speed GROUP BY 1\n"
        "    template_type: system\n    template: line",  # no newline at the end, as there
        "report.resim.yml",
    )
    code, lines = _check(capsys, "--strict", config, report)
    assert code == 0
    assert lines == [
        f"warning: {report}: metrics 'Trend': type 'report' is read as 'dashboard', "
        "its current name"
    ]
    assert load_config([config, report]).metrics["Trend"].level == "dashboard"


@pytest.mark.parametrize(
    ("settings", "problem"),
    [
        ("refresh: sometimes", "'refresh' must be auto or manual, not 'sometimes'"),
        ("day_range: lots", "'day_range' must be a positive whole number, not 'lots'"),
        ("day_range: 0", "'day_range' must be a positive whole number, not 0"),
        ("day_range: true", "'day_range' must be a positive whole number, not True"),
        ("description: [a, b]", "'description' must be text"),
    ],
)
def test_a_bad_dashboard_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], settings: str, problem: str
) -> None:
    text = (
        f"{HEAD}metrics:\n{GOOD_METRIC}metrics sets:\n  main: {{metrics: [Max speed]}}\n"
        f"dashboards:\n  Trends: {{metrics_set: main, {settings}}}\n"
    )
    config = _write(tmp_path, text)
    code, lines = _check(capsys, config)
    assert code == 2
    assert lines == [f"{config}: dashboards 'Trends': {problem}"]


def test_a_dashboard_names_a_known_metrics_set(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = _write(tmp_path, f"{HEAD}dashboards:\n  Trends: {{metrics_set: nope}}\n")
    assert _check(capsys, config) == (
        2,
        [f"{config}: dashboards 'Trends': names unknown metrics set 'nope'"],
    )


def test_a_dashboard_is_read_whole(tmp_path: Path) -> None:
    text = (
        f"{HEAD}metrics:\n{GOOD_METRIC}metrics sets:\n  main: {{metrics: [Max speed]}}\n"
        "dashboards:\n  Trends: {metrics_set: main, description: Weekly, refresh: manual, "
        "day_range: 30}\n"
    )
    (dashboard,) = load_config([_write(tmp_path, text)]).dashboards.values()
    assert (dashboard.name, dashboard.metrics_set, dashboard.description) == (
        "Trends",
        "main",
        "Weekly",
    )
    assert (dashboard.refresh, dashboard.day_range) == ("manual", 30)


def test_a_dashboard_defined_in_two_files_is_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    first = _write(tmp_path, f"{HEAD}dashboards:\n  Trends: {{refresh: auto}}\n", "a.yml")
    second = _write(tmp_path, "version: 1\ndashboards:\n  Trends: {refresh: manual}\n", "b.yml")
    code, lines = _check(capsys, first, second)
    assert code == 2
    assert lines == [f"{second}: dashboards name 'Trends' is also defined in {first}"]


def test_image_and_video_columns_in_one_topic_are_refused(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    media = "version: 1\ntopics:\n  camera: {schema: {frame: image, clip: video, note: string}}\n"
    config = _write(tmp_path, media)
    code, lines = _check(capsys, config)
    assert code == 2
    assert lines == [
        f"{config}: topics 'camera': has image column(s) 'frame' and video column(s) 'clip'; "
        "the platform takes one kind of media per topic: emit the images and the videos in "
        "two topics"
    ]
    # Two image columns, or the kinds in two topics: good.
    _write(tmp_path, media.replace("clip: video", "clip: image"))
    assert _check(capsys, config) == (0, [])
    two = "version: 1\ntopics:\n  frames: {schema: {frame: image}}\n"
    two += "  clips: {schema: {clip: video}}\n"
    _write(tmp_path, two)
    assert _check(capsys, config) == (0, [])


@pytest.mark.parametrize(
    ("template_file", "problem"),
    [
        ("sub/figure.liquid", "is not a file name; the platform takes only the files at the top"),
        ("figure.json", "must be a .liquid file"),
        ("missing.liquid", "no such file"),
    ],
)
def test_templates_come_only_from_the_top_of_the_templates_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], template_file: str, problem: str
) -> None:
    templates = tmp_path / "templates"
    (templates / "sub").mkdir(parents=True)
    for name in ("sub/figure.liquid", "figure.json", "figure.liquid"):
        (templates / name).write_text("{}", encoding="utf-8")
    metric = (
        "  Figure:\n    type: test\n    query_string: SELECT speed FROM speed\n"
        f"    template_type: custom\n    template_file: {template_file}\n"
    )
    config = _write(tmp_path, HEAD + "metrics:\n" + metric)
    code, lines = _check(capsys, config)
    assert code == 2
    (line,) = lines
    assert f"{config}: metrics 'Figure'" in line
    assert problem in line
    # The same metric with a template at the top level: good.
    _write(tmp_path, HEAD + "metrics:\n" + metric.replace(template_file, "figure.liquid"))
    assert _check(capsys, config) == (0, [])


def test_a_single_file_without_version_is_accepted_as_by_the_sdk(tmp_path: Path) -> None:
    from resim.sdk.metrics.emissions import merge_metrics_config_files

    config = _write(tmp_path, HEAD.replace("version: 1\n", "") + "metrics:\n" + GOOD_METRIC)
    assert "version" not in merge_metrics_config_files([config])  # ReSim's SDK takes it
    loaded = load_config([config])
    assert loaded.version is None
    assert list(loaded.metrics) == ["Max speed"]


@pytest.mark.parametrize("version", ['"1"', "1.0", "true"])
def test_a_version_that_is_not_an_integer_is_refused(tmp_path: Path, version: str) -> None:
    config = _write(tmp_path, HEAD.replace("version: 1", f"version: {version}"))
    with pytest.raises(MetricsConfigError, match="'version' must be an integer"):
        load_config([config])


def test_a_key_given_twice_is_refused_with_its_line(tmp_path: Path) -> None:
    text = f"{HEAD}metrics:\n{GOOD_METRIC}    type: batch\n"
    config = _write(tmp_path, text)
    with pytest.raises(MetricsConfigError) as caught:
        load_config([config])
    assert caught.value.problems == [f"{config} line 9: key 'type' is given twice in one mapping"]


def test_the_yaml_twin_of_a_yml_path_is_read(tmp_path: Path) -> None:
    _write(tmp_path, HEAD, "config.resim.yaml")
    config = load_config([tmp_path / "config.resim.yml"])
    assert config.files == (tmp_path / "config.resim.yaml",)


def test_read_config_keeps_the_usable_parts(tmp_path: Path) -> None:
    text = f"{HEAD}metrics:\n{GOOD_METRIC}  Broken:\n    type: weekly\n    query_string: SELECT 1\n"
    config, problems = read_config([_write(tmp_path, text)])
    assert list(config.metrics) == ["Max speed"]
    assert len(problems) == 2  # the type, and the missing template


def test_load_config_logs_the_warnings_once(tmp_path: Path) -> None:
    from structlog.testing import capture_logs

    config = _write(tmp_path, HEAD + "metrics:\n" + GOOD_METRIC + "    unit: m/s\n")
    with capture_logs() as logs:
        loaded = load_config([config])
    expected = f"{config}: metrics 'Max speed': unknown key 'unit' (did you mean 'units'?)"
    assert loaded.warnings == (expected,)
    assert [(log["log_level"], log["event"]) for log in logs] == [("warning", expected)]
    with pytest.raises(MetricsConfigError, match="unknown key 'unit'"):
        load_config([config], strict=True)


def test_a_file_that_cannot_be_read_is_said_alone(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    sets = _write(tmp_path, "version: 1\nmetrics sets:\n  main: {metrics: [Max speed]}\n", "s.yml")
    broken = _write(tmp_path, HEAD + "metrics:\n" + GOOD_METRIC + "  [unclosed\n", "m.yml")
    code, lines = _check(capsys, broken, sets)
    assert code == 2
    (line,) = lines  # not one more for the set naming a metric of the unread file
    assert line.startswith(f"{broken} line ")
    assert "not YAML" in line
