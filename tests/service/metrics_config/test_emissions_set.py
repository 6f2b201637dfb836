"""EmissionsSet, the API batch and report mode feed job by job: bytes, files or nothing
per job, one frame per topic with the ID columns, the metadata table."""

from __future__ import annotations

import json
from pathlib import Path

import polars as pl
import pytest

from stook.service.metrics_config import EmissionsError, EmissionsSet, JobMeta, load_config

CONFIG = """\
version: 1
topics:
  speed:
    schema: {lane: string, speed: float, ok: boolean, n: int, tags: 'string[]', m: 'metric[]'}
  quiet:
    schema: {x: float}
"""


def _line(data: dict[str, object], timestamp: int | None = None) -> str:
    meta: dict[str, object] = {"topic": "speed"}
    if timestamp is not None:
        meta["timestamp"] = timestamp
    return json.dumps({"$metadata": meta, "$data": data})


def _row(i: int) -> dict[str, object]:
    return {"lane": "l", "speed": i + 0.5, "ok": i % 2 == 0, "n": i, "tags": ["a"], "m": []}


def test_jobs_from_bytes_files_and_nothing(tmp_path: Path) -> None:
    (tmp_path / "c.yml").write_text(CONFIG, encoding="utf-8")
    config = load_config([tmp_path / "c.yml"])
    emissions = EmissionsSet(config)
    emissions.add_job(
        JobMeta(
            job_id="j1",
            batch_id="b",
            experience_name="e1",
            build_version="1.2",
            job_conflated_status="PASSED",
            tags=("nightly",),
        ),
        "\n".join(_line(_row(i), timestamp=i * 10) for i in range(3)).encode(),
    )
    path = tmp_path / "j2.jsonl"
    path.write_text(_line({**_row(7), "speed": 3}) + "\n\n", encoding="utf-8")  # an int float
    emissions.add_job(JobMeta(job_id="j2", batch_id="b"), path)
    emissions.add_job(JobMeta(job_id="j3", batch_id="b"), None)  # no emissions log
    tables = emissions.tables()

    speed = tables["speed"]
    assert speed.columns == [
        "lane",
        "speed",
        "ok",
        "n",
        "tags",
        "m",
        "timestamp",
        "job_id",
        "batch_id",
        "experience_name",
        "build_version",
    ]
    assert speed.schema["n"] == pl.Int64
    assert speed.schema["tags"] == pl.List(pl.String)
    assert speed["job_id"].to_list() == ["j1", "j1", "j1", "j2"]
    assert speed["speed"].to_list() == [0.5, 1.5, 2.5, 3.0]
    assert speed["timestamp"].to_list() == [0, 10, 20, None]
    assert speed["build_version"].to_list() == ["1.2"] * 3 + [None]
    assert tables["quiet"].height == 0
    assert tables["quiet"].columns[0] == "x"
    metadata = tables["metadata"]
    assert metadata["job_id"].to_list() == ["j1", "j2", "j3"]
    assert metadata["tags"].to_list() == [["nightly"], [], []]
    assert metadata["job_conflated_status"].to_list() == ["PASSED", None, None]


def test_a_bad_row_in_bytes_is_named_by_the_source(tmp_path: Path) -> None:
    (tmp_path / "c.yml").write_text(CONFIG, encoding="utf-8")
    emissions = EmissionsSet(load_config([tmp_path / "c.yml"]))
    good = _line(_row(1))
    bad = _line({**_row(2), "tags": ["a", 3]})
    emissions.add_job(JobMeta(job_id="j1"), f"{good}\n".encode())
    emissions.add_job(
        JobMeta(job_id="j2"), f"{good}\n{good}\n{bad}\n".encode(), name="job j2's log"
    )
    with pytest.raises(EmissionsError) as caught:
        emissions.tables()
    assert str(caught.value) == (
        "job j2's log line 3: topic 'speed', column 'tags': expected a list of strings, "
        "got a list of mixed types"
    )


def test_job_metadata_from_a_mapping() -> None:
    meta = JobMeta.from_mapping({"job_id": "j", "tags": ["x"], "build_version": 3})
    assert (meta.job_id, meta.tags, meta.build_version) == ("j", ("x",), "3")
    with pytest.raises(EmissionsError, match="unknown key\\(s\\) 'colour'"):
        JobMeta.from_mapping({"job_id": "j", "colour": "red"})
    with pytest.raises(EmissionsError, match="'job_id' is required"):
        JobMeta.from_mapping({"batch_id": "b"})


def test_blank_lines_and_crlf_keep_the_line_numbers(tmp_path: Path) -> None:
    (tmp_path / "c.yml").write_text(CONFIG, encoding="utf-8")
    emissions = EmissionsSet(load_config([tmp_path / "c.yml"]))
    good = _line(_row(1))
    bad = _line({**_row(2), "n": True})
    emissions.add_job(JobMeta(job_id="j1"), f"{good}\r\n \t\r\n\r\n{good}\r\n".encode())
    emissions.add_job(JobMeta(job_id="j2"), f"\n  \n{good}\n{bad}".encode(), name="log 2")
    with pytest.raises(EmissionsError) as caught:
        emissions.tables()
    assert str(caught.value) == (
        "log 2 line 4: topic 'speed', column 'n': expected int, got a boolean"
    )


def test_crlf_rows_load(tmp_path: Path) -> None:
    (tmp_path / "c.yml").write_text(CONFIG, encoding="utf-8")
    emissions = EmissionsSet(load_config([tmp_path / "c.yml"]))
    text = "\r\n".join(_line(_row(i), timestamp=i) for i in range(3)) + "\r\n"
    emissions.add_job(JobMeta(job_id="j1"), text.encode())
    speed = emissions.tables()["speed"]
    assert speed["n"].to_list() == [0, 1, 2]
    assert speed["lane"].to_list() == ["l", "l", "l"]
