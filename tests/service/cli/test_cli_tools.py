"""`stook show`, `stook validate` and `stook emulate` from the command line."""

from __future__ import annotations

import importlib.metadata
import json
import os
import queue
import signal
import subprocess
import sys
import threading
import time
import urllib.request
import uuid
from collections.abc import Iterator
from datetime import UTC, datetime, timedelta
from pathlib import Path

import pytest
import resim.metrics.proto.metrics_pb2 as resim_pb
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as validate_resim

from stook.sdk import MetricStatus, MetricsWriter, MetricType, data, read_job_metrics
from stook.sdk.example import every_metric_type
from stook.service.cli import run_cli
from tests.failures import failure_lines

JOB = uuid.UUID("0b7a4c1e-5d2f-4e8a-9c3b-6f1d2e3a4b5c")
T0 = datetime(2026, 1, 1, tzinfo=UTC)
CLI = [sys.executable, "-c", "from stook.service.cli import main; main()"]


def _known_writer() -> MetricsWriter:
    w = MetricsWriter(JOB, deterministic=True)
    w.scalar("Max speed", 31.25, unit="m/s", fails_above=30.0)
    w.scalar("Count", 7.0)
    times = data.timestamps("Time", [T0 + timedelta(seconds=i) for i in range(5)])
    w.double_over_time("Speed over time", data.doubles("Speed", [1.0, 2, 3, 4, 5], index=times))
    w.text("Notes", "First line of the notes\nsecond line", status=MetricStatus.FAIL_BLOCK)
    w.histogram("Speeds", data.doubles("speeds", [1.0, 2.0, 3.0]), buckets=2, lower=0, upper=4)
    return w


@pytest.fixture
def known_file(tmp_path: Path) -> Path:
    return _known_writer().write(tmp_path / "metrics.binproto")


@pytest.fixture
def example_file(tmp_path: Path) -> Path:
    w = MetricsWriter(JOB, deterministic=True)
    every_metric_type(tmp_path, tmp_path, w)
    return w.write(tmp_path / "example.binproto")


@pytest.fixture
def invalid_file(tmp_path: Path) -> Path:
    w = MetricsWriter(JOB, deterministic=True)
    w.scalar("fine", 1.0)
    w.scalar("broken", 1.0).proto.status = 0  # type: ignore[assignment]
    w.text("empty text", "x").proto.metric_values.text_metric_values.text = ""
    return w.write(tmp_path / "invalid.binproto", validate=False)


def _error_lines(err: str) -> list[str]:
    return failure_lines(err)


def _row(out: str, name: str) -> list[str]:
    rows = [line for line in out.splitlines() if line.startswith(name + "  ")]
    assert len(rows) == 1, out
    return rows[0].split()


# ---------------------------------------------------------------- show


def test_show_prints_one_line_per_metric_with_type_status_and_value(
    known_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert run_cli(["show", str(known_file)]) == 0
    out, err = capsys.readouterr()
    lines = out.splitlines()
    view = read_job_metrics(known_file.read_bytes())
    assert lines[0] == f"5 metrics, {len(view.data)} metrics data, overall status FAIL_BLOCK"
    assert lines[1].split() == ["metric", "type", "status", "value"]
    assert set(lines[2].replace(" ", "")) == {"-"}
    assert len(lines) == 3 + 5
    assert _row(out, "Max speed")[2:] == ["SCALAR", "FAIL_WARN", "31.25", "m/s"]
    assert _row(out, "Count")[1:] == ["SCALAR", "PASSED", "7"]
    assert _row(out, "Notes")[1:] == ["TEXT", "FAIL_BLOCK", "First", "line", "of", "the", "notes"]
    assert _row(out, "Speeds")[1:] == ["HISTOGRAM", "PASSED", "3", "values"]
    assert _row(out, "Speed over time")[3:5] == ["DOUBLE_OVER_TIME", "PASSED"]
    assert "error" not in err


def test_show_covers_every_metric_type_of_the_example(
    example_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert run_cli(["show", str(example_file)]) == 0
    out, _ = capsys.readouterr()
    body = out.splitlines()[3:]
    view = read_job_metrics(example_file.read_bytes())
    assert len(body) == len(view.metrics) == 14
    for line, metric in zip(body, view.metrics, strict=True):
        assert isinstance(metric.type, MetricType)
        assert isinstance(metric.status, MetricStatus)
        assert line.startswith(metric.name[:56])
        assert f"  {metric.type.name}  " in line
        assert f"  {metric.status.name}" in line
    assert {m.type for m in view.metrics} == set(MetricType)
    assert _row(out, "Min gap to lead vehicle")[-3:] == ["PASSED", "4.2", "m"]
    assert _row(out, "Detections per class")[-2:] == ["3", "values"]


def test_show_reads_an_invalid_but_readable_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    w = MetricsWriter(JOB)
    w.scalar("unset", 2.5).proto.status = 0  # type: ignore[assignment]
    path = w.write(tmp_path / "f.binproto", validate=False)
    assert run_cli(["show", str(path)]) == 0
    out, _ = capsys.readouterr()
    assert _row(out, "unset")[1:] == ["SCALAR", "?", "2.5"]


def test_show_and_validate_read_unknown_enum_values(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """A newer schema's enum values: shown by number, and valid as ReSim's validator says."""
    w = _known_writer()
    msg = w.to_proto()
    count = next(m for m in msg.job_level_metrics.metrics if m.name == "Count")
    count.status = 42  # type: ignore[assignment]
    count.importance = 9  # type: ignore[assignment]
    path = tmp_path / "newer.binproto"
    path.write_bytes(msg.SerializeToString())
    resim_msg = resim_pb.JobMetrics.FromString(path.read_bytes())
    validate_resim(resim_msg)  # ReSim's validator accepts it: so must ours

    assert run_cli(["show", str(path)]) == 0
    out, err = capsys.readouterr()
    assert _row(out, "Count")[1:] == ["SCALAR", "unknown", "(42)", "7"]
    assert _row(out, "Max speed")[2:4] == ["SCALAR", "FAIL_WARN"]
    assert run_cli(["validate", str(path)]) == 0
    out, err = capsys.readouterr()
    assert out.startswith(f"{path}: valid")
    assert "error" not in err


def test_show_survives_a_text_metric_with_empty_text(
    invalid_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert run_cli(["show", str(invalid_file)]) == 0
    out, _ = capsys.readouterr()
    # The name holds a space: the row's cells start after it.
    assert _row(out, "empty text")[2:4] == ["TEXT", "PASSED"]


def test_show_counts_values_not_statuses(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    w = MetricsWriter(JOB)
    times = data.timestamps("Time", [1, 2, 3])
    speed = data.doubles("Speed", [1.0, 2.0, 3.0], index=times)
    statuses = data.statuses("Speed checks", [MetricStatus.PASSED] * 3, index=times)
    w.double_over_time("Speed over time", speed, statuses=[statuses])
    path = w.write(tmp_path / "f.binproto")
    assert run_cli(["show", str(path)]) == 0
    out, _ = capsys.readouterr()
    assert _row(out, "Speed over time")[-2:] == ["3", "values"]


# ---------------------------------------------------------------- validate


def test_validate_a_good_file(known_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(["validate", str(known_file)]) == 0
    out, err = capsys.readouterr()
    view = read_job_metrics(known_file.read_bytes())
    assert out == f"{known_file}: valid (5 metrics, {len(view.data)} metrics data)\n"
    assert _error_lines(err) == []


def test_validate_the_example(example_file: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert run_cli(["validate", str(example_file)]) == 0
    out, _ = capsys.readouterr()
    assert out.startswith(f"{example_file}: valid (14 metrics, ")


def test_validate_an_invalid_file_lists_every_problem_and_exits_4(
    invalid_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert run_cli(["validate", str(invalid_file)]) == 4
    out, err = capsys.readouterr()
    problems = [line for line in out.splitlines() if line.startswith(f"{invalid_file}: ")]
    assert len(problems) == 2
    assert problems[0].startswith(f"{invalid_file}: metric 'broken' (id ")
    assert problems[0].endswith("): the metric status is unset")
    assert problems[1].startswith(f"{invalid_file}: metric 'empty text' (id ")
    assert problems[1].endswith("): a text metric needs non-empty text")
    assert not any("'fine'" in line for line in out.splitlines())
    errors = _error_lines(err)
    assert len(errors) == 1
    assert errors[0].startswith("stook: error: metric 'broken' (id ")
    assert errors[0].endswith("the metric status is unset (and 1 more)")


@pytest.mark.parametrize(
    ("content", "reason"),
    [
        (b"\xff\xff\xff\xff", "not a valid protobuf message"),
        (b"", "no bytes (an empty file is a failed or truncated write)"),
    ],
)
def test_validate_and_show_refuse_garbage_with_exit_4(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], content: bytes, reason: str
) -> None:
    path = tmp_path / "garbage.binproto"
    path.write_bytes(content)
    for command in ("validate", "show"):
        assert run_cli([command, str(path)]) == 4
        out, err = capsys.readouterr()
        errors = _error_lines(err)
        assert len(errors) == 1, err
        assert str(path) in errors[0]
        assert "could not read JobMetrics" in errors[0]
        assert reason in errors[0]
        assert not any(line.startswith(str(path)) for line in out.splitlines())


def test_validate_refuses_a_truncated_file_with_exit_4(
    known_file: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    payload = known_file.read_bytes()
    known_file.write_bytes(payload[: len(payload) // 2])
    assert run_cli(["validate", str(known_file)]) == 4
    _, err = capsys.readouterr()
    (error,) = _error_lines(err)
    assert str(known_file) in error
    assert "could not read JobMetrics" in error


def test_the_file_name_of_an_unreadable_file_is_quoted_once(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    path = tmp_path / "garbage.binproto"
    path.write_bytes(b"\xff\xff")
    assert run_cli(["validate", str(path)]) == 4
    _, err = capsys.readouterr()
    assert f"could not read JobMetrics from '{path}': " in err


def test_validate_and_show_a_missing_file(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # A file that is not there is a usage error (2), not invalid data (4).
    path = tmp_path / "nowhere" / "metrics.binproto"
    for command in ("validate", "show"):
        code = run_cli([command, str(path)])
        assert code == 2
        out, err = capsys.readouterr()
        assert out == ""
        (error,) = _error_lines(err)
        assert error == f"stook: error: '{path}': no such file"


def test_a_missing_file_as_a_process_is_said_once_in_json(tmp_path: Path) -> None:
    path = tmp_path / "metrics.binproto"
    for command in ("validate", "show"):
        done = subprocess.run(
            [*CLI, command, str(path)],
            capture_output=True,
            text=True,
            timeout=60,
            env={**os.environ, "STOOK_LOG_FORMAT": "json"},
        )
        assert done.returncode == 2
        assert done.stdout == ""
        (line,) = done.stderr.splitlines()
        event = json.loads(line)
        assert (event["event"], event["exit_code"]) == ("stook failed", 2)
        assert event["error"] == f"'{path}': no such file"


def test_version() -> None:
    done = subprocess.run([*CLI, "--version"], capture_output=True, text=True, timeout=60)
    assert done.returncode == 0
    assert done.stderr == ""
    versions = {d: importlib.metadata.version(d) for d in ("stook", "stook-sdk", "stook-proto")}
    assert done.stdout == (
        f"stook {versions['stook']} "
        f"(stook-sdk {versions['stook-sdk']}, stook-proto {versions['stook-proto']})\n"
    )


# What `show` and `validate` must not import: they read a file, with protobuf alone. (How
# fast they start is measured in `stook bench`, not here.)
_HEAVY = ("polars", "numpy", "aiohttp")


@pytest.mark.parametrize("command", ["show", "validate", "--version", "--help"])
def test_inspecting_a_file_imports_no_heavy_library(command: str, known_file: Path) -> None:
    script = (
        "import sys\n"
        "from stook.service.cli import main\n"
        "try:\n"
        "    main()\n"
        "except SystemExit as stop:\n"
        f"    heavy = [m for m in {_HEAVY!r} if m in sys.modules]\n"
        "    print('HEAVY', heavy, file=sys.stderr)\n"
        "    raise\n"
    )
    args = [command] if command.startswith("--") else [command, str(known_file)]
    done = subprocess.run(
        [sys.executable, "-c", script, *args], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    assert "HEAVY []" in done.stderr


def test_validate_without_a_file_is_a_usage_error(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exit_info:
        run_cli(["validate"])
    assert exit_info.value.code == 2
    assert "the following arguments are required: file" in capsys.readouterr().err


def test_validate_as_a_process(invalid_file: Path, known_file: Path) -> None:
    good = subprocess.run(
        [*CLI, "validate", str(known_file)], capture_output=True, text=True, timeout=60
    )
    assert good.returncode == 0
    assert good.stdout.startswith(f"{known_file}: valid (5 metrics, ")
    bad = subprocess.run(
        [*CLI, "validate", str(invalid_file)], capture_output=True, text=True, timeout=60
    )
    assert bad.returncode == 4
    assert len(_error_lines(bad.stderr)) == 1
    assert sum(line.startswith(f"{invalid_file}: ") for line in bad.stdout.splitlines()) == 2


def test_validate_as_a_process_prints_only_problems_on_stdout(invalid_file: Path) -> None:
    bad = subprocess.run(
        [*CLI, "validate", str(invalid_file)], capture_output=True, text=True, timeout=60
    )
    assert bad.returncode == 4
    assert all(line.startswith(f"{invalid_file}: ") for line in bad.stdout.splitlines())


# ---------------------------------------------------------------- emulate


def _lines(stream: object) -> queue.Queue[str | None]:
    found: queue.Queue[str | None] = queue.Queue()

    def pump() -> None:
        for line in stream:  # type: ignore[attr-defined]
            found.put(line)
        found.put(None)

    threading.Thread(target=pump, daemon=True).start()
    return found


@pytest.fixture
def emulate(tmp_path: Path) -> Iterator[tuple[subprocess.Popen[str], Path, list[str]]]:
    inputs = tmp_path / "inputs"
    proc = subprocess.Popen(
        [*CLI, "emulate", "--jobs", "5", "--inputs", str(inputs), "--log-format", "json"],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
    )
    lines = _lines(proc.stdout)
    seen: list[str] = []
    try:
        deadline = time.monotonic() + 30
        while not any("Press Ctrl-C" in line for line in seen):
            remaining = deadline - time.monotonic()
            assert remaining > 0, f"emulator not ready in 30 s: {seen}"
            try:
                line = lines.get(timeout=remaining)
            except queue.Empty:
                continue
            assert line is not None, f"emulator exited early: {seen}, {proc.stderr}"
            seen.append(line.rstrip("\n"))
        yield proc, inputs, seen
    finally:
        if proc.poll() is None:
            proc.kill()
        proc.wait(timeout=10)
        for stream in (proc.stdout, proc.stderr):
            if stream is not None:
                stream.close()


def test_emulate_prints_the_api_url_and_writes_the_batch_config(
    emulate: tuple[subprocess.Popen[str], Path, list[str]],
) -> None:
    proc, inputs, seen = emulate
    assert seen[0] == "ReSim emulator ready"
    fields = dict(line.strip().split(":", 1) for line in seen[1:-1])
    fields = {k.strip(): v.strip() for k, v in fields.items()}
    api_url = fields["apiURL"]
    assert api_url.startswith("http://127.0.0.1:")
    assert api_url.endswith("/v1")
    config_path = inputs / "batch_metrics_config.json"
    assert fields["wrote"] == str(config_path)
    assert fields["batchID"].endswith("(5 jobs)")
    config = json.loads(config_path.read_text())
    assert config == {
        "authToken": fields["authToken"],
        "apiURL": api_url,
        "batchID": fields["batchID"].split()[0],
        "projectID": fields["projectID"],
    }
    # The URL serves the batch of 5 jobs that the config names.
    request = urllib.request.Request(
        f"{api_url}/projects/{config['projectID']}/batches/{config['batchID']}/jobs",
        headers={"Authorization": f"Bearer {config['authToken']}"},
    )
    with urllib.request.urlopen(request, timeout=10) as answer:
        body = json.loads(answer.read())
    assert body["total"] == 5
    # Ctrl-C stops it: its normal end, said at level info, not as an error.
    proc.send_signal(signal.SIGINT)
    assert proc.wait(timeout=15) == 130
    assert proc.stderr is not None
    events = [json.loads(line) for line in proc.stderr.read().splitlines() if line.strip()]
    assert [(e["event"], e["level"]) for e in events if e["event"] == "emulator stopped"] == [
        ("emulator stopped", "info")
    ]
    assert not [e for e in events if e["level"] == "error"]


@pytest.mark.parametrize("command", [["demo"], ["emulate"], ["bench", "--quick"]])
def test_testing_commands_say_what_to_install_without_stook_testing(
    command: list[str], tmp_path: Path
) -> None:
    # As in a metrics-build image: stook installed, stook-testing not.
    hide = (
        "import sys\n"
        "for name in ('stook.emulator', 'stook.testing', 'stook.bench'):\n"
        "    sys.modules[name] = None\n"
        "from stook.service.cli import main\n"
        "main()\n"
    )
    done = subprocess.run(
        [sys.executable, "-c", hide, *command, "--log-format", "console"]
        if command[0] != "bench"
        else [sys.executable, "-c", hide, *command, "--out", str(tmp_path)],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2, done.stderr
    assert failure_lines(done.stderr) == [
        f"stook: error: 'stook {command[0]}' needs the stook-testing distribution, which is "
        "not installed (from a checkout: 'make setup', or 'pip install ./service/testing')"
    ], done.stderr
    assert list(tmp_path.iterdir()) == []
