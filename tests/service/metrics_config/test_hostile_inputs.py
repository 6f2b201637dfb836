"""Rows and job folders as a hostile user or a broken test writes them (issue 38): each
one refused with its file (and line), exit 2 or 4, nothing written; and the inputs the
SDK writes on its own machine (emissions_<job_id>.resim.jsonl) accepted."""

from __future__ import annotations

import datetime as dt
import json
import os
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from stook.sdk import TextMetric, read_job_metrics
from stook.service.cli._main import run_cli
from stook.service.metrics_config import EmissionsSet, JobMeta, find_jobs, load_config
from tests.service.metrics_config.emitted import JobData, emit_job, make_job

DEEP = "[" * 10_000 + "]" * 10_000


@pytest.fixture(autouse=True)
def _console_errors(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STOOK_LOG_FORMAT", "console")


def _stderr(capsys: pytest.CaptureFixture[str]) -> str:
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert "recursion" not in err
    return err


def _eval(config: Path, emissions: Path, out: Path, level: str = "test") -> int:
    args = ["metrics-config", "eval", str(config), "--emissions", str(emissions)]
    return run_cli([*args, "--level", level, "--outputs", str(out)])


def _collision(metrics: str = "[]", meta: str = '"timestamp": 5, "event": true') -> str:
    return (
        f'{{"$metadata": {{"topic": "collision", {meta}}}, "$data": {{"name": "c", '
        f'"description": "", "status": "PASSED", "tags": [], "metrics": {metrics}}}}}'
    )


SPEED = '{"$metadata": {"topic": "speed", "timestamp": 1}, "$data": {"lane": "a", "speed": 1.0}}'


@pytest.mark.parametrize(
    ("line", "problem"),
    [
        (SPEED.replace("1.0}", "1.0,}"), "a trailing comma (column 87)"),
        (SPEED.replace('"a",', '"a", "lane": "b",'), "the key 'lane' is given twice"),
        (SPEED.replace('"a",', '"a", "lane" : "b",'), "the key 'lane' is given twice"),
        (
            SPEED.replace('"speed", ', '"speed", "topic": "lidar", '),
            "the key 'topic' is given twice",
        ),
        (
            SPEED.replace('"timestamp": 1', '"timestamp": 9223372036854775808'),
            "topic 'speed': '$metadata.timestamp' does not fit 64 bits",
        ),
        (
            _collision().replace('"tags": []', '"tags": [null, "rear"]'),
            "topic 'collision', column 'tags': null is not a string (in a list of strings)",
        ),
        (
            _collision('[null, 1, "x", [1]]'),  # the Emitter writes this
            "topic 'collision', column 'metrics': entry 0 is not a metric object",
        ),
        (
            _collision('[{"name": "v", "value": 1}, {"name": "v", "value": 2}]'),
            "topic 'collision', column 'metrics': two event metrics are named 'v'",
        ),
        (
            _collision(meta='"timestamp": -5, "event": true'),
            "topic 'collision': an event's '$metadata.timestamp' must not be negative",
        ),
        (
            _collision(meta='"event": true'),
            "topic 'collision': an event needs a '$metadata.timestamp'",
        ),
        (SPEED.replace('"a"', DEEP), "nested deeper than 64 levels"),
        (_collision().replace('"tags": []', f'"tags": {DEEP}'), "nested deeper than 64 levels"),
        (_collision(f"[{DEEP}]"), "nested deeper than 64 levels"),
        (_collision(f'[{{"name": "v", "value": {DEEP}}}]'), "nested deeper than 64 levels"),
        (DEEP, "nested deeper than 64 levels"),
        (
            SPEED.replace('"a"', '"\\ud800"'),  # json.dumps of a lone surrogate
            "not a JSON object (no low surrogate in string, byte 76)",
        ),
    ],
    ids=lambda case: case[:40] if isinstance(case, str) else None,
)
def test_a_hostile_row_is_refused_with_file_and_line(
    tmp_path: Path,
    config: Path,
    one_job: tuple[Path, JobData],
    capsys: pytest.CaptureFixture[str],
    line: str,
    problem: str,
) -> None:
    emissions, _ = one_job
    rows = emissions.read_text(encoding="utf-8").splitlines()
    rows.insert(3, line)
    emissions.write_text("\n".join(rows) + "\n", encoding="utf-8")
    out = tmp_path / "out"
    assert _eval(config, emissions, out) == 4
    (said,) = _stderr(capsys).splitlines()
    assert f"{emissions} line 4: {problem}" in said
    assert not out.exists()


def test_the_earliest_bad_line_is_named_whatever_its_kind(
    tmp_path: Path, config: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    emissions = tmp_path / "emissions.resim.jsonl"
    lines = [SPEED, SPEED.replace("1.0", "true"), SPEED.replace("1.0}", "1.0,}")]
    emissions.write_text("\n".join(lines) + "\n", encoding="utf-8")
    assert _eval(config, emissions, tmp_path / "out") == 4
    assert f"{emissions} line 2: topic 'speed', column 'speed'" in _stderr(capsys)
    emissions.write_text("\n".join([lines[0], lines[2], lines[1]]) + "\n", encoding="utf-8")
    assert _eval(config, emissions, tmp_path / "out") == 4
    assert f"{emissions} line 2: a trailing comma" in _stderr(capsys)


def test_invalid_utf8_is_named_by_its_line(
    tmp_path: Path, config: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    emissions = tmp_path / "emissions.resim.jsonl"
    bad = SPEED.replace('"a"', '"\xe9"').encode("latin-1")
    emissions.write_bytes(f"{SPEED}\n".encode() * 4 + bad)
    assert _eval(config, emissions, tmp_path / "out") == 4
    assert f"{emissions} line 5: not UTF-8 (byte 70 of the line)" in _stderr(capsys)


def test_json_text_inside_a_string_is_a_value_not_a_problem(tmp_path: Path) -> None:
    # `":` and `,]` inside strings make a line suspect; decoding it clears it.
    config = tmp_path / "c.yml"
    config.write_text("version: 1\ntopics:\n  t:\n    schema: {s: string, n: int}\n")
    value = '{"a": 1, "b": [1,], "c" : 2}'
    line = json.dumps({"$metadata": {"topic": "t"}, "$data": {"s": value, "n": 3}})
    emissions = EmissionsSet(load_config([config]))
    emissions.add_job(JobMeta(job_id="j"), f"{line}\n{line}\n".encode())
    frame = emissions.tables()["t"]
    assert frame["s"].to_list() == [value, value]
    assert frame["n"].to_list() == [3, 3]


def _batch_of_two(tmp_path: Path, config: Path) -> Path:
    batch = tmp_path / "batch"
    for k in range(2):
        emit_job(batch / f"job-{k}", config, make_job(k), meta={"job_id": f"job-{k}"})
    return batch


def _folder(path: Path) -> None:
    path.unlink()
    path.mkdir()


def _loop(path: Path) -> None:
    path.unlink()
    path.symlink_to(path.name)  # itself: "Too many levels of symbolic links"


def _fifo(path: Path) -> None:
    path.unlink()
    os.mkfifo(path)  # reading it would wait for ever


def _dangling(path: Path) -> None:
    path.unlink()
    path.symlink_to("gone")


def _text(text: str) -> Callable[[Path], None]:
    def write(path: Path) -> None:
        path.write_text(text, encoding="utf-8")

    return write


@pytest.mark.parametrize(
    ("spoil", "at", "problem"),
    [
        (_folder, "emissions.resim.jsonl", "a folder, not a file"),
        (_loop, "emissions.resim.jsonl", "cannot be read (Too many levels of symbolic links)"),
        (_folder, "job.json", "a folder, not a file"),
        (_loop, "job.json", "cannot be read"),
        (_fifo, "job.json", "neither a file nor a folder"),
        (_dangling, "job.json", "no such file or folder"),
        (_text(DEEP), "job.json", "nested deeper than 64 levels"),
        (
            _text('{\n  "job_id": "a",\n  "tags": ["x",]\n}'),
            "job.json",
            "a trailing comma (line 3, column 16)",
        ),
        (_text('{"job_id": "a", "job_id": "b"}'), "job.json", "the key 'job_id' is given twice"),
        (_text('["job_id"]'), "job.json", "must be a JSON object"),
        (
            _text('{"job_id": "a", "custom_field_keys": ["k"]}'),
            "job.json",
            "1 custom_field_keys but 0 custom_field_values",
        ),
        (
            _text('{"job_id": "a", "build_creation_timestamp": "soon"}'),
            "job.json",
            "'build_creation_timestamp' must be an RFC 3339 time",
        ),
    ],
)
def test_a_job_folder_that_cannot_be_read_is_named(
    tmp_path: Path,
    config: Path,
    capsys: pytest.CaptureFixture[str],
    spoil: Callable[[Path], None],
    at: str,
    problem: str,
) -> None:
    batch = _batch_of_two(tmp_path, config)
    path = batch / "job-1" / at
    spoil(path)
    out = tmp_path / "out"
    assert _eval(config, batch, out, "batch") == 2
    (said,) = _stderr(capsys).splitlines()
    assert f"{path}: {problem}" in said
    assert not out.exists()


def test_two_job_jsons_of_one_job_id_are_both_named(
    tmp_path: Path, config: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    batch = _batch_of_two(tmp_path, config)
    for k in range(2):
        (batch / f"job-{k}" / "job.json").write_text('{"job_id": "same-id"}')
    assert _eval(config, batch, tmp_path / "out", "batch") == 2
    (said,) = _stderr(capsys).splitlines()
    first, second = batch / "job-0" / "job.json", batch / "job-1" / "job.json"
    assert f"job_id 'same-id' is given twice: by {first} and by {second}" in said


def test_a_job_folder_with_job_json_and_no_emissions_is_a_job_without_rows(
    tmp_path: Path, config: Path
) -> None:
    batch = _batch_of_two(tmp_path, config)
    (batch / "job-1" / "emissions.resim.jsonl").unlink()
    (batch / "templates").mkdir()  # neither file: no job's folder
    jobs = find_jobs([batch])
    assert [(j.meta.job_id, j.emissions is None) for j in jobs] == [
        ("job-0", False),
        ("job-1", True),
    ]


def test_the_sdks_local_layout_is_a_batch_of_jobs(
    tmp_path: Path, config: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    # resim.sdk.Test writes emissions_<job_id>.resim.jsonl in the working folder.
    from resim.sdk.metrics.emissions import Emitter

    folder = tmp_path / "run"
    folder.mkdir()
    ids = sorted(str(uuid.UUID(int=k + 1)) for k in range(3))
    for k, job_id in enumerate(ids):
        with Emitter(
            config_path=config, output_path=folder / f"emissions_{job_id}.resim.jsonl"
        ) as e:
            e.emit_series("speed", {"lane": ["a", "b"], "speed": [1.0 + k, 2.0]}, [1, 2])
    (folder / "notes.txt").write_text("not a job")
    jobs = find_jobs([folder])
    assert [j.meta.job_id for j in jobs] == ids
    assert len({j.meta.batch_id for j in jobs}) == 1
    single = find_jobs([folder / f"emissions_{ids[0]}.resim.jsonl"])
    assert single[0].meta.job_id == ids[0]
    out = tmp_path / "out"
    assert _eval(config, folder, out, "batch") == 0
    assert (out / "metrics.binproto").is_file()
    (folder / f"emissions_{ids[0]}.resim.jsonl").unlink()
    (folder / f"emissions_{ids[0]}.resim.jsonl").mkdir()
    assert _eval(config, folder, tmp_path / "out2", "batch") == 2
    assert f"emissions_{ids[0]}.resim.jsonl: a folder, not an emissions file" in _stderr(capsys)


METADATA_CONFIG = """\
version: 1
topics:
  speed:
    schema: {lane: string, speed: float}
metrics:
  Lighting:
    type: batch
    query_string: |
      SELECT job_id AS "Job",
        custom_field_values[array_position(custom_field_keys, 'Lighting')] AS "Lighting",
        year(build_creation_timestamp) AS "Built"
      FROM metadata WHERE cardinality(custom_field_keys) > 0 ORDER BY job_id
    template: table
"""


def test_job_json_custom_fields_and_build_time_reach_metadata(tmp_path: Path) -> None:
    config = tmp_path / "config.resim.yml"
    config.write_text(METADATA_CONFIG)
    batch = tmp_path / "batch"
    metas: list[dict[str, Any]] = [
        {
            "job_id": "a",
            "custom_field_keys": ["Weather", "Lighting"],
            "custom_field_values": ["rain", "dusk"],
            "build_creation_timestamp": "2025-01-18T14:03:00Z",
        },
        {
            "job_id": "b",
            "custom_field_keys": ["Lighting"],
            "custom_field_values": ["noon"],
            "build_creation_timestamp": "2024-12-31T23:30:00-02:00",
        },
        # No custom fields: empty arrays (not read by the query, whose subscript would
        # raise on it as Trino's does).
        {"job_id": "c"},
    ]
    for meta in metas:
        (batch / meta["job_id"]).mkdir(parents=True)
        (batch / meta["job_id"] / "emissions.resim.jsonl").write_text(SPEED + "\n")
        (batch / meta["job_id"] / "job.json").write_text(json.dumps(meta))
    jobs = find_jobs([batch])
    emissions = EmissionsSet(load_config([config]))
    for job in jobs:
        emissions.add_job(job.meta, job.emissions)
    metadata = emissions.tables()["metadata"]
    assert metadata["custom_field_keys"].to_list() == [["Weather", "Lighting"], ["Lighting"], []]
    assert metadata["custom_field_values"].to_list() == [["rain", "dusk"], ["noon"], []]
    assert metadata["build_creation_timestamp"].to_list() == [
        dt.datetime(2025, 1, 18, 14, 3),
        dt.datetime(2025, 1, 1, 1, 30),  # UTC
        None,
    ]
    out = tmp_path / "out"
    assert _eval(config, batch, out, "batch") == 0
    table = read_job_metrics((out / "metrics.binproto").read_bytes())
    text = table.metric("Lighting", TextMetric).text.splitlines()
    rows = [line.replace(" ", "") for line in text[2:]]
    assert rows[0] == "|a|dusk|2025|"
    assert rows[1] == "|b|noon|2025|"  # 23:30 at -02:00 is the next year in UTC


def test_timestamps_at_the_ends_of_int64_load_and_tables_can_be_built_twice(
    tmp_path: Path,
) -> None:
    config = tmp_path / "c.yml"
    config.write_text("version: 1\ntopics:\n  t:\n    schema: {n: int}\n")
    stamps = [-(2**63), 2**63 - 1, None]
    lines = [
        json.dumps(
            {
                "$metadata": {"topic": "t", **({} if s is None else {"timestamp": s})},
                "$data": {"n": 2**63 - 1},
            }
        )
        for s in stamps
    ]
    emissions = EmissionsSet(load_config([config]))
    emissions.add_job(JobMeta(job_id="j"), "\n".join(lines).encode())
    for _ in range(2):
        frame = emissions.tables()["t"]
        assert frame["timestamp"].to_list() == stamps
        assert frame["n"].to_list() == [2**63 - 1] * 3
