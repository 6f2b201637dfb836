"""stook.toml parsing, inputs-folder detection, option precedence and exit codes."""

from __future__ import annotations

import json
import tomllib
import uuid
from pathlib import Path
from typing import Any

import pytest
import structlog.testing

from stook.sdk._errors import InvalidMetricsError, Problem, ReadError, StookError, WriterError
from stook.sdk.aggregations import JobStatusCounts, MergedHistogram, ScalarStats, WeightedMean
from stook.service.api._errors import ApiError, AuthError, RetriesExhaustedError
from stook.service.cli._run import (
    DEFAULT_INPUTS,
    DEFAULT_OUTPUTS,
    ExitCode,
    exit_code_for,
    resolve_options,
)
from stook.service.cli._usage import UsageError
from stook.service.modes import (
    ConfigError,
    InputsError,
    MissingJobsError,
    UserFunctionError,
    _config,
    _inputs,
)
from stook.service.modes._config import FetchSettings, ReportSettings, StookConfig, load, parse
from stook.service.modes._inputs import ApiAccess, BatchInputs, ReportInputs, detect

# ================================================================ stook.toml

DOCSTRING_EXAMPLE = (_config.__doc__ or "").split("\n\n", 1)[1]


def write_toml(tmp_path: Path, text: str) -> Path:
    path = tmp_path / "stook.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_the_docstring_example_parses(tmp_path: Path) -> None:
    assert "[[batch.weighted_mean]]" in DOCSTRING_EXAMPLE
    path = write_toml(tmp_path, DOCSTRING_EXAMPLE)
    config = load(path)
    assert config.source == str(path)
    assert config.fetch == FetchSettings(
        concurrency=64, timeout=30.0, retry_for=120.0, deadline=1800.0, page_size=100
    )
    assert config.test_metrics == "my_metrics.test:compute"
    assert config.batch_defaults is True
    built = config.batch_aggregations()
    assert len(built) == 1
    wm = built[0]
    assert isinstance(wm, WeightedMean)
    assert (wm.name, wm.metric, wm.weight) == (
        "Distance-weighted localization error",
        "Localization error",
        "Distance driven",
    )
    # Each call builds fresh aggregations: no state is shared between runs.
    assert config.batch_aggregations()[0] is not wm


def test_a_full_config(tmp_path: Path) -> None:
    path = write_toml(
        tmp_path,
        """
[fetch]
concurrency = 8
timeout = 5
retry_for = 30
deadline = 600
page_size = 50

[batch]
defaults = false

[[batch.histogram]]
name = "Speed"
data = "speed"
lower = 0
upper = 40
buckets = 8

[[batch.scalar_stats]]
metric = "lat"
stats = ["p99"]

[[batch.job_status_counts]]

[report]
top_n = 5
regression_threshold = 4
job_metrics = ["Localization error"]
""",
    )
    config = load(path)
    assert config.fetch == FetchSettings(
        concurrency=8, timeout=5.0, retry_for=30.0, deadline=600.0, page_size=50
    )
    assert isinstance(config.fetch.timeout, float)
    assert isinstance(config.fetch.retry_for, float)
    assert isinstance(config.fetch.deadline, float)
    assert config.batch_defaults is False
    assert config.test_metrics is None
    assert config.report == ReportSettings(
        top_n=5, regression_threshold=4.0, job_metrics=("Localization error",)
    )
    assert isinstance(config.report.regression_threshold, float)
    assert [type(a) for a in config.batch_aggregations()] == [
        MergedHistogram,
        ScalarStats,
        JobStatusCounts,
    ]


def test_no_config_is_the_defaults() -> None:
    config = load(None)
    assert config == StookConfig()
    assert config.source == "(built-in defaults)"
    assert config.batch_defaults is True
    assert config.batch_aggregations() == []
    assert parse({}).fetch == FetchSettings()


def test_bad_toml_names_the_file_and_line(tmp_path: Path) -> None:
    path = write_toml(tmp_path, "[fetch]\nconcurrency = 4\ntimeout = \n[batch]\n")
    with pytest.raises(ConfigError) as info:
        load(path)
    message = str(info.value)
    assert message.startswith(f"{path}: not valid TOML (")
    assert "line 3" in message


def test_a_missing_or_unreadable_file(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"config file '.*nope\.toml' does not exist"):
        load(tmp_path / "nope.toml")
    with pytest.raises(ConfigError, match="cannot be read"):
        load(tmp_path)  # a directory
    bad = tmp_path / "latin1.toml"
    bad.write_bytes(b"[fetch]\n# caf\xe9\n")
    with pytest.raises(ConfigError, match=r"cannot be read \(UnicodeDecodeError\)"):
        load(bad)


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        pytest.param(
            {"fetsh": {}},
            "s.toml: unknown section 'fetsh' (known: batch, engine, fetch, metrics_config, "
            "output, report, test)",
            id="unknown-section",
        ),
        pytest.param(
            {"fetch": {"concurrency": 4, "retries": 3}},
            "s.toml: unknown key 'retries' in [fetch] "
            "(known: adaptive, concurrency, deadline, max_api_body_mb, max_body_mb, "
            "page_size, retry_for, timeout)",
            id="unknown-fetch-key",
        ),
        pytest.param(
            {"test": {"metrics": "a:b", "function": "c"}},
            "s.toml: unknown key 'function' in [test] (known: metrics)",
            id="unknown-test-key",
        ),
        pytest.param({"fetch": 3}, "s.toml: [fetch] must be a table", id="fetch-not-a-table"),
        pytest.param({"batch": [1]}, "s.toml: [batch] must be a table", id="batch-not-a-table"),
        pytest.param(
            {"fetch": {"concurrency": "64"}},
            's.toml: [fetch] concurrency must be a positive integer, got the string "64"',
            id="string-number",
        ),
        pytest.param(
            {"fetch": {"concurrency": True}},
            "s.toml: [fetch] concurrency must be a positive integer, got the boolean true",
            id="bool-number",
        ),
        pytest.param(
            {"fetch": {"timeout": 0}},
            "s.toml: [fetch] timeout must be a positive number, got 0",
            id="zero",
        ),
        pytest.param(
            {"fetch": {"retry_for": -1}},
            "s.toml: [fetch] retry_for must be a positive number, got -1",
            id="negative",
        ),
        pytest.param(
            {"fetch": {"deadline": 0}},
            "s.toml: [fetch] deadline must be a positive number, got 0",
            id="zero-deadline",
        ),
        pytest.param(
            {"fetch": {"page_size": 10.5}},
            "s.toml: [fetch] page_size must be a positive integer, got the float 10.5",
            id="fraction",
        ),
        pytest.param(
            {"fetch": {"page_size": 101}},
            "s.toml: [fetch] page_size must be at most 100 (the API's limit), got 101",
            id="page-size-above-the-spec",
        ),
        pytest.param(
            {"test": {"metrics": 5}},
            "s.toml: [test] metrics must be 'package.module:function'",
            id="metrics-not-a-string",
        ),
        pytest.param(
            {"test": {"metrics": "my_metrics.compute"}},
            "s.toml: [test] metrics must be 'package.module:function'",
            id="metrics-without-colon",
        ),
        pytest.param(
            {"batch": {"defaults": "yes"}},
            "s.toml: [batch] defaults must be true or false",
            id="defaults-not-bool",
        ),
        pytest.param(
            {"batch": {"nope": [{}]}},
            "s.toml: [[batch.nope]] #1: unknown aggregation kind 'nope'",
            id="unknown-kind",
        ),
        pytest.param(
            {"batch": {"weighted_mean": [{"name": "n", "metric": "m"}, {"name": "n"}]}},
            "s.toml: [[batch.weighted_mean]] #2: ",
            id="missing-option",
        ),
    ],
)
def test_bad_configs(doc: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError) as info:
        parse(doc, source="s.toml")
    assert str(info.value).startswith(message)


# Every number setting of stook.toml: its table, its key, and what it must be.
NUMBER_SETTINGS = [
    *(("fetch", key, "a positive integer") for key in ("concurrency", "page_size")),
    *(
        ("fetch", key, "a positive number")
        for key in ("timeout", "retry_for", "deadline", "max_body_mb", "max_api_body_mb")
    ),
    *(("report", key, "a positive integer") for key in ("top_n", "regression_window")),
    *(("report", key, "a positive number") for key in ("regression_threshold", "change_penalty")),
    *(("engine", key, "a positive integer") for key in ("workers", "shards")),
    ("batch.baseline", "confidence", "a number from 0.5 to 0.999"),
    ("batch.baseline", "min_effect", "a number from 0 to 10"),
    ("batch.baseline", "resamples", "an integer from 100 to 100000"),
]


@pytest.mark.parametrize(("table", "key", "wanted"), NUMBER_SETTINGS)
@pytest.mark.parametrize(
    ("value", "got"),
    [
        ("64", 'the string "64"'),
        (True, "the boolean true"),
        (-3, "-3"),
        (float("nan"), "the float nan"),
        ([1], "an array"),
    ],
)
def test_a_bad_number_setting_says_what_it_got(
    table: str, key: str, wanted: str, value: object, got: str
) -> None:
    """One check for every number setting: what it must be, and what the file gave."""
    if table == "batch.baseline":
        doc: dict[str, Any] = {"batch": {"baseline": {"previous": True, key: value}}}
    else:
        doc = {table: {key: value}}
    with pytest.raises(ConfigError) as info:
        parse(doc, source="stook.toml")
    assert str(info.value) == f"stook.toml: [{table}] {key} must be {wanted}, got {got}"


@pytest.mark.parametrize(
    ("table", "key"), [(t, k) for t, k, wanted in NUMBER_SETTINGS if "integer" in wanted]
)
def test_a_whole_number_setting_refuses_a_float(table: str, key: str) -> None:
    doc: dict[str, Any] = (
        {"batch": {"baseline": {"previous": True, key: 1000.0}}}
        if table == "batch.baseline"
        else {table: {key: 8.0}}
    )
    with pytest.raises(ConfigError, match=r"must be (a positive|an) integer.*, got the float"):
        parse(doc, source="stook.toml")


def test_retry_counts_of_old_configs_are_accepted_ignored_and_warned_about() -> None:
    """`max_attempts` and `max_throttled_attempts` gave way to the time budget `retry_for`:
    a config written for them still loads, and says once that they no longer count."""
    with structlog.testing.capture_logs() as logs:
        fetch = parse(
            {"fetch": {"max_attempts": 2, "max_throttled_attempts": 9}}, source="s.toml"
        ).fetch
    assert fetch == FetchSettings()
    warned = [e for e in logs if e["event"] == "deprecated setting ignored"]
    assert [e["setting"] for e in warned] == [
        "[fetch] max_attempts",
        "[fetch] max_throttled_attempts",
    ]
    assert all("retry_for" in e["hint"] and e["log_level"] == "warning" for e in warned)


def test_fetch_float_timeout_is_fine_and_int_is_kept_whole() -> None:
    fetch = parse({"fetch": {"timeout": 2.5, "concurrency": 1}}).fetch
    assert fetch == FetchSettings(concurrency=1, timeout=2.5)


def test_histogram_written_as_a_table_gets_a_clear_error(tmp_path: Path) -> None:
    path = write_toml(
        tmp_path,
        '[batch.histogram]\nname = "Speed"\ndata = "speed"\nlower = 0\nupper = 40\n',
    )
    with pytest.raises(ConfigError) as info:
        load(path)
    assert str(info.value) == (
        f"{path}: [batch.histogram] must be an array of tables: write [[batch.histogram]]"
    )


def test_bad_batch_tables_fail_at_parse_time(tmp_path: Path) -> None:
    path = write_toml(
        tmp_path,
        '[[batch.histogram]]\nname = "H"\ndata = "d"\nlower = 5\nupper = 1\n',
    )
    with pytest.raises(ConfigError, match=r"\[\[batch\.histogram\]\] #1: .*lower < upper"):
        load(path)


def test_wrong_option_types_in_batch_tables_are_config_errors() -> None:
    with pytest.raises(ConfigError, match=r"\[\[batch\.weighted_mean\]\] #1") as info:
        parse({"batch": {"weighted_mean": [{"name": 5, "metric": "x"}]}})
    assert "option 'name' cannot be 5 (expected str)" in str(info.value)
    with pytest.raises(ConfigError, match=r"option 'buckets' cannot be 2\.5"):
        parse(
            {
                "batch": {
                    "histogram": [
                        {"name": "h", "data": "d", "lower": 0, "upper": 1, "buckets": 2.5}
                    ]
                }
            }
        )
    with pytest.raises(ConfigError, match="option 'stats' cannot be"):
        parse({"batch": {"scalar_stats": [{"metric": "m", "stats": ["mean", 3]}]}})
    # ints are fine where floats are expected
    parse({"batch": {"histogram": [{"name": "h", "data": "d", "lower": 0, "upper": 1}]}})


def test_toml_types_round_trip() -> None:
    # What tomllib hands parse() for an array of tables: a list of dicts.
    doc = tomllib.loads('[[batch.pass_rate]]\nname = "PR"\n')
    assert parse(doc).batch_tables == {"pass_rate": [{"name": "PR"}]}


# ================================================================ inputs folder

TOKEN = "tok-SECRET-4f1e9b"
PROJECT = uuid.UUID("aaaaaaaa-bbbb-4ccc-8ddd-eeeeeeeeeeee")
BATCH = uuid.UUID("12345678-1234-4234-8234-123456789abc")
REPORT = uuid.UUID("87654321-4321-4321-8321-cba987654321")


def batch_doc(**changes: Any) -> dict[str, Any]:
    doc: dict[str, Any] = {
        "authToken": TOKEN,
        "apiURL": "https://api.resim.ai/v1/",
        "batchID": str(BATCH),
        "projectID": str(PROJECT),
    }
    doc.update(changes)
    return {k: v for k, v in doc.items() if v is not None}


def report_doc(**changes: Any) -> dict[str, Any]:
    doc = batch_doc(**changes)
    doc.pop("batchID", None)
    doc.setdefault("reportID", str(REPORT))
    return {k: v for k, v in doc.items() if v is not None}


def put(folder: Path, name: str, doc: dict[str, Any] | str) -> Path:
    path = folder / name
    path.write_text(doc if isinstance(doc, str) else json.dumps(doc, indent=2), encoding="utf-8")
    return path


def detect_error(folder: Path, **kwargs: Any) -> str:
    with pytest.raises(InputsError) as info:
        detect(folder, **kwargs)
    message = str(info.value)
    assert TOKEN not in message
    assert TOKEN not in repr(info.value)
    return message


def test_batch_config_means_batch_mode(tmp_path: Path) -> None:
    put(tmp_path, "batch_metrics_config.json", batch_doc())
    mode = detect(tmp_path)
    assert mode == BatchInputs(
        access=ApiAccess(api_url="https://api.resim.ai/v1", token=TOKEN, project_id=PROJECT),
        batch_id=BATCH,
    )
    assert TOKEN not in repr(mode)
    assert TOKEN not in str(mode)
    assert TOKEN not in repr(mode.access)


def test_report_config_wins_over_batch_config(tmp_path: Path) -> None:
    put(tmp_path, "batch_metrics_config.json", batch_doc())
    put(tmp_path, "report_config.json", report_doc(apiURL="http://localhost:8080"))
    mode = detect(tmp_path)
    assert isinstance(mode, ReportInputs)
    assert mode.report_id == REPORT
    assert mode.access.api_url == "http://localhost:8080"
    assert mode.access.project_id == PROJECT
    assert TOKEN not in repr(mode)


def test_a_broken_report_config_is_not_skipped_for_the_batch_one(tmp_path: Path) -> None:
    put(tmp_path, "batch_metrics_config.json", batch_doc())
    put(tmp_path, "report_config.json", "{")
    assert detect_error(tmp_path).startswith("report_config.json: not valid JSON")


def test_neither_config_means_test_mode(tmp_path: Path) -> None:
    (tmp_path / "experience").mkdir()
    mode = detect(tmp_path)
    assert mode == _inputs.TestInputs(
        experience_dir=tmp_path / "experience", logs_dir=tmp_path / "logs"
    )


def test_a_missing_inputs_folder(tmp_path: Path) -> None:
    assert detect_error(tmp_path / "absent") == (
        f"inputs folder {str(tmp_path / 'absent')!r} does not exist"
    )


def test_malformed_json_names_the_file_and_the_line(tmp_path: Path) -> None:
    text = '{\n  "authToken": "' + TOKEN + '",\n  "apiURL": "https://x"\n  "batchID": "1"\n}\n'
    put(tmp_path, "batch_metrics_config.json", text)
    assert detect_error(tmp_path) == (
        "batch_metrics_config.json: not valid JSON (Expecting ',' delimiter at line 4 column 3)"
    )


def test_json_that_is_not_an_object(tmp_path: Path) -> None:
    put(tmp_path, "batch_metrics_config.json", "[1, 2]")
    assert detect_error(tmp_path) == "batch_metrics_config.json: must hold a JSON object, not list"


def test_undecodable_file(tmp_path: Path) -> None:
    (tmp_path / "batch_metrics_config.json").write_bytes(b'{"authToken": "\xff"}')
    assert detect_error(tmp_path) == (
        "batch_metrics_config.json: cannot be read (UnicodeDecodeError)"
    )


@pytest.mark.parametrize("key", ["authToken", "apiURL", "batchID"])
def test_missing_key(tmp_path: Path, key: str) -> None:
    put(tmp_path, "batch_metrics_config.json", batch_doc(**{key: None}))
    assert detect_error(tmp_path) == f"batch_metrics_config.json: missing key {key!r}"


@pytest.mark.parametrize("value", ["", "   ", 42, None])
def test_empty_or_non_string_token(tmp_path: Path, value: Any) -> None:
    doc = batch_doc()
    doc["authToken"] = value
    put(tmp_path, "batch_metrics_config.json", doc)
    assert detect_error(tmp_path) == (
        "batch_metrics_config.json: 'authToken' must be a non-empty string"
    )


def test_non_uuid_batch_id(tmp_path: Path) -> None:
    put(tmp_path, "batch_metrics_config.json", batch_doc(batchID="batch-42"))
    assert (
        detect_error(tmp_path) == "batch_metrics_config.json: 'batchID' is not a UUID: 'batch-42'"
    )


def test_a_long_non_uuid_is_shortened(tmp_path: Path) -> None:
    put(tmp_path, "report_config.json", report_doc(reportID="x" * 100))
    assert detect_error(tmp_path) == (
        f"report_config.json: 'reportID' is not a UUID: '{'x' * 37}...'"
    )


def test_missing_project_id_in_a_batch_config(tmp_path: Path) -> None:
    put(tmp_path, "batch_metrics_config.json", batch_doc(projectID=None))
    assert detect_error(tmp_path) == (
        "batch_metrics_config.json: missing key 'projectID' (older batch configs lack it); "
        "pass --project-id or set STOOK_PROJECT_ID"
    )
    override = uuid.UUID("00000000-0000-4000-8000-000000000001")
    mode = detect(tmp_path, project_id=override)
    assert isinstance(mode, BatchInputs)
    assert mode.access.project_id == override


def test_missing_project_id_in_a_report_config(tmp_path: Path) -> None:
    put(tmp_path, "report_config.json", report_doc(projectID=None))
    assert detect_error(tmp_path) == (
        "report_config.json: missing key 'projectID'; pass --project-id or set STOOK_PROJECT_ID"
    )
    mode = detect(tmp_path, project_id=PROJECT)
    assert isinstance(mode, ReportInputs)
    assert mode.access.project_id == PROJECT


def test_the_config_project_id_wins_over_the_override(tmp_path: Path) -> None:
    put(tmp_path, "batch_metrics_config.json", batch_doc())
    mode = detect(tmp_path, project_id=uuid.UUID(int=7))
    assert isinstance(mode, BatchInputs)
    assert mode.access.project_id == PROJECT


def test_non_uuid_project_id(tmp_path: Path) -> None:
    put(tmp_path, "batch_metrics_config.json", batch_doc(projectID="proj"))
    assert detect_error(tmp_path, project_id=PROJECT) == (
        "batch_metrics_config.json: 'projectID' is not a UUID: 'proj'"
    )


@pytest.mark.parametrize(
    "url", ["ftp://api.resim.ai", "api.resim.ai/v1", "https://", "file:///etc/passwd", "  "]
)
def test_non_http_api_url(tmp_path: Path, url: str) -> None:
    put(tmp_path, "batch_metrics_config.json", batch_doc(apiURL=url))
    message = detect_error(tmp_path)
    assert message in (
        "batch_metrics_config.json: 'apiURL' is not an http(s) URL",
        "batch_metrics_config.json: 'apiURL' must be a non-empty string",
    )
    if url.strip():
        assert message.endswith("is not an http(s) URL")


def test_the_token_never_leaks_from_any_error(tmp_path: Path) -> None:
    # Put the token next to every kind of breakage; detect_error checks each message.
    cases: list[dict[str, Any] | str] = [
        batch_doc(batchID="nope"),
        batch_doc(apiURL="gopher://x"),
        batch_doc(projectID=None),
        batch_doc(projectID=TOKEN[:5]),
        '{"authToken": "' + TOKEN + '", ]',
        '{"authToken": "' + TOKEN,
    ]
    for case in cases:
        put(tmp_path, "batch_metrics_config.json", case)
        detect_error(tmp_path)
    assert TOKEN not in repr(ApiAccess("https://x", TOKEN, PROJECT))


# ================================================================ resolve_options

STOOK_ENV = (
    "STOOK_CONFIG",
    "STOOK_INPUTS",
    "STOOK_OUTPUTS",
    "STOOK_ALLOW_MISSING_JOBS",
    "STOOK_PROJECT_ID",
)


@pytest.fixture
def env(monkeypatch: pytest.MonkeyPatch) -> pytest.MonkeyPatch:
    for name in STOOK_ENV:
        monkeypatch.delenv(name, raising=False)
    return monkeypatch


def options(cwd: Path, **flags: Any) -> Any:
    given: dict[str, Any] = {
        "inputs": None,
        "outputs": None,
        "config": None,
        "allow_missing_jobs": None,
        "project_id": None,
    }
    given.update(flags)
    return resolve_options(cwd=cwd, **given)


def test_defaults(env: pytest.MonkeyPatch, tmp_path: Path) -> None:
    got = options(tmp_path)
    assert got.inputs == DEFAULT_INPUTS == Path("/tmp/resim/inputs")
    assert got.outputs == DEFAULT_OUTPUTS == Path("/tmp/resim/outputs")
    assert got.config is None
    assert got.allow_missing_jobs == 0.0
    assert got.project_id is None


def test_environment_over_defaults(env: pytest.MonkeyPatch, tmp_path: Path) -> None:
    env.setenv("STOOK_INPUTS", "/env/in")
    env.setenv("STOOK_OUTPUTS", "/env/out")
    env.setenv("STOOK_CONFIG", "/env/stook.toml")
    env.setenv("STOOK_ALLOW_MISSING_JOBS", "0.25")
    env.setenv("STOOK_PROJECT_ID", str(PROJECT))
    write_toml(tmp_path, "")  # the environment's config wins over ./stook.toml
    got = options(tmp_path)
    assert (got.inputs, got.outputs, got.config) == (
        Path("/env/in"),
        Path("/env/out"),
        Path("/env/stook.toml"),
    )
    assert got.allow_missing_jobs == 0.25
    assert got.project_id == PROJECT


def test_flags_over_environment(env: pytest.MonkeyPatch, tmp_path: Path) -> None:
    for name in STOOK_ENV:
        env.setenv(name, "/env/x" if name != "STOOK_ALLOW_MISSING_JOBS" else "0.5")
    env.setenv("STOOK_PROJECT_ID", str(PROJECT))
    flag_project = "00000000-0000-4000-8000-0000000000ff"
    got = options(
        tmp_path,
        inputs="/flag/in",
        outputs="/flag/out",
        config="/flag/stook.toml",
        allow_missing_jobs=0.0,  # falsy, still a flag
        project_id=flag_project,
    )
    assert (got.inputs, got.outputs, got.config) == (
        Path("/flag/in"),
        Path("/flag/out"),
        Path("/flag/stook.toml"),
    )
    assert got.allow_missing_jobs == 0.0
    assert got.project_id == uuid.UUID(flag_project)


def test_local_stook_toml_is_picked_when_present(env: pytest.MonkeyPatch, tmp_path: Path) -> None:
    assert options(tmp_path).config is None
    (tmp_path / "stook.toml").mkdir()  # a folder of that name is not a config
    assert options(tmp_path).config is None
    (tmp_path / "stook.toml").rmdir()
    path = write_toml(tmp_path, "")
    assert options(tmp_path).config == path
    assert options(tmp_path, config="/other.toml").config == Path("/other.toml")


@pytest.mark.parametrize("share", [1.5, -0.1, float("nan")])
def test_bad_allow_missing_jobs_flag(env: pytest.MonkeyPatch, tmp_path: Path, share: float) -> None:
    with pytest.raises(UsageError, match="--allow-missing-jobs must be a fraction from 0 to 1"):
        options(tmp_path, allow_missing_jobs=share)


def test_allow_missing_jobs_bounds_are_inclusive(env: pytest.MonkeyPatch, tmp_path: Path) -> None:
    assert options(tmp_path, allow_missing_jobs=1.0).allow_missing_jobs == 1.0
    assert options(tmp_path, allow_missing_jobs=0.0).allow_missing_jobs == 0.0


def test_bad_allow_missing_jobs_environment(env: pytest.MonkeyPatch, tmp_path: Path) -> None:
    env.setenv("STOOK_ALLOW_MISSING_JOBS", "ten percent")
    with pytest.raises(UsageError, match="STOOK_ALLOW_MISSING_JOBS must be a number from 0 to 1"):
        options(tmp_path)
    env.setenv("STOOK_ALLOW_MISSING_JOBS", "2")
    with pytest.raises(UsageError, match="got 2"):
        options(tmp_path)
    env.setenv("STOOK_ALLOW_MISSING_JOBS", "")  # empty: unset
    assert options(tmp_path).allow_missing_jobs == 0.0
    env.setenv("STOOK_ALLOW_MISSING_JOBS", "ten percent")
    assert options(tmp_path, allow_missing_jobs=0.3).allow_missing_jobs == 0.3


def test_bad_project_id(env: pytest.MonkeyPatch, tmp_path: Path) -> None:
    with pytest.raises(UsageError, match="project ID 'proj-1' is not a UUID"):
        options(tmp_path, project_id="proj-1")
    env.setenv("STOOK_PROJECT_ID", "nope")
    with pytest.raises(UsageError, match="project ID 'nope' is not a UUID"):
        options(tmp_path)


# ================================================================ exit codes


@pytest.mark.parametrize(
    ("error", "code"),
    [
        (UsageError("bad flag"), ExitCode.USAGE),
        (ConfigError("bad toml"), ExitCode.USAGE),
        (InputsError("bad json"), ExitCode.USAGE),
        (WriterError("two metrics named x"), ExitCode.USAGE),
        (ApiError("down"), ExitCode.API),
        (AuthError(status=401, method="GET", url="https://api.example/x"), ExitCode.API),
        (
            RetriesExhaustedError(
                method="GET", url="https://api.example/x", attempts=6, last_reason="timeout"
            ),
            ExitCode.API,
        ),
        (MissingJobsError("3 of 4 jobs missing"), ExitCode.API),
        (ReadError("truncated"), ExitCode.INVALID_DATA),
        (InvalidMetricsError([Problem("metric 'x'", "broken")]), ExitCode.INVALID_DATA),
        (UserFunctionError("boom"), ExitCode.UNEXPECTED),
        (StookError("some other stook error"), ExitCode.UNEXPECTED),
        (ValueError("plain"), ExitCode.UNEXPECTED),
        (RuntimeError("unexpected"), ExitCode.UNEXPECTED),
        (KeyboardInterrupt(), ExitCode.UNEXPECTED),
    ],
    ids=lambda v: type(v).__name__ if isinstance(v, BaseException) else str(v),
)
def test_exit_code_for(error: BaseException, code: ExitCode) -> None:
    assert exit_code_for(error) is code


def test_exit_code_values_are_the_documented_ones() -> None:
    assert [int(c) for c in ExitCode] == [0, 1, 2, 3, 4, 5]
    assert [c.name for c in ExitCode] == [
        "OK",
        "UNEXPECTED",
        "USAGE",
        "API",
        "INVALID_DATA",
        "OUTPUT",
    ]


def test_fetch_adaptive_is_read_from_the_config() -> None:
    assert parse({}).fetch.adaptive is False
    assert parse({"fetch": {"adaptive": True}}).fetch.adaptive is True
    with pytest.raises(ConfigError, match="adaptive must be true or false"):
        parse({"fetch": {"adaptive": "yes"}})
