"""A seeded fuzz of emissions and job folders (issue 38), beside test_errors.py and
test_hostile_inputs.py: legal rows written through ReSim's own `Emitter` load with the
values it was given; each hostile mutation of one line is refused naming that file and
line; each spoilt job folder is refused naming the path. The quick tier runs a few
seeds, the slow tier many, and whole `stook metrics-config eval` processes."""

from __future__ import annotations

import json
import math
import os
import random
import subprocess
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from stook.service.metrics_config import (
    EmissionsError,
    EmissionsSet,
    JobMeta,
    MetricsConfig,
    find_jobs,
    load_config,
)

CONFIG = """\
version: 1
topics:
  sample:
    schema:
      flag: boolean
      count: int
      value: float
      label: string
      state: status
      names: string[]
  bump:
    event: true
    schema:
      name: string
      description: string
      status: status
      tags: string[]
      metrics: metric[]
metrics:
  Samples:
    type: test
    query_string: SELECT COUNT(*) AS n FROM sample
    template: scalar
"""

# Text that the lenient reader and the line tests must both get right: quotes, colons,
# commas before brackets, escapes, non-ASCII, what json.dumps escapes.
_PIECES = ['"', '":', ",]", ",}", "\\", "\n", "\t", "é", "☃", "😀", "{", "[", " : ", "\x01", "x"]


def _text(rng: random.Random) -> str:
    return "".join(rng.choice(_PIECES) for _ in range(rng.randrange(0, 6)))


def _int(rng: random.Random) -> int:
    return rng.choice([0, 1, -1, 2**63 - 1, -(2**63), rng.randrange(-(2**63), 2**63)])


def _float(rng: random.Random) -> float:
    return rng.choice([0.0, -0.0, 1.5, 1e300, -1e-300, rng.uniform(-1e6, 1e6), math.nan, math.inf])


def _sample(rng: random.Random) -> dict[str, Any]:
    return {
        "flag": rng.random() < 0.5,
        "count": _int(rng),
        "value": _float(rng) if rng.random() < 0.8 else rng.randrange(-5, 5),
        "label": _text(rng),
        "state": rng.choice(["PASSED", "FAIL_WARN", _text(rng)]),
        "names": [_text(rng) for _ in range(rng.randrange(0, 4))],
    }


def _bump(rng: random.Random) -> dict[str, Any]:
    entries = []
    for k in range(rng.randrange(0, 4)):
        value: Any = rng.choice([1.5, 7, "text", None, {"a": [1, {"b": "c"}]}, [1, 2]])
        entries.append({"name": f"m{k}{_text(rng)}", "type": "scalar", "value": value})
    return {
        "name": _text(rng) or "bump",
        "description": _text(rng),
        "status": rng.choice(["PASSED", "FAIL_WARN", "FAIL_BLOCK"]),
        "tags": [_text(rng) for _ in range(rng.randrange(0, 3))],
        "metrics": entries,
    }


def write_legal(path: Path, config: Path, rng: random.Random, rows: int) -> list[Any]:
    """Rows written by ReSim's Emitter (validating against the config); what each line
    holds, in order: ("sample", data, timestamp or None) or ("bump", data, timestamp)."""
    from resim.sdk.metrics.emissions import Emitter

    written: list[Any] = []
    with Emitter(config_path=config, output_path=path) as emitter:
        for _ in range(rows):
            if rng.random() < 0.8:
                data = _sample(rng)
                stamp = rng.choice([None, rng.randrange(0, 2**63)])
                emitter.emit("sample", data, timestamp=stamp)
                written.append(("sample", data, stamp))
            else:
                data = _bump(rng)
                stamp = rng.randrange(0, 2**63)
                emitter.emit_event("bump", data, timestamp=stamp)
                written.append(("bump", data, stamp))
    return written


def _same(a: Any, b: Any) -> bool:
    if isinstance(a, float) and isinstance(b, float | int):
        return (math.isnan(a) and math.isnan(b)) or a == b
    return bool(a == b)


def check_loaded(config: MetricsConfig, path: Path, written: list[Any]) -> None:
    emissions = EmissionsSet(config)
    emissions.add_job(JobMeta(job_id="j"), path)
    tables = emissions.tables()
    for topic in ("sample", "bump"):
        rows = [(data, stamp) for t, data, stamp in written if t == topic]
        frame = tables[topic].to_dicts()
        assert len(frame) == len(rows)
        for got, (data, stamp) in zip(frame, rows, strict=True):
            assert got["timestamp"] == stamp
            for column, value in data.items():
                if column == "metrics":
                    assert [json.loads(e) for e in got[column]] == value
                else:
                    assert _same(got[column], value), (column, got[column], value)


# Hostile mutations of one line (its JSON text, and what it holds) into text that JSON
# Lines, the Emitter's schema or int64 forbid. Each returns the new line, or None when it
# does not apply to this line.
def _trailing_comma(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    return line[:-2] + ",}}"


def _duplicate_key(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    key = rng.choice(sorted(row["$data"]))
    spaced = rng.choice(['"{}": ', '"{}" : ', '"\\u00{:02x}{}": '])
    name = spaced.format(ord(key[0]), key[1:]) if "\\u" in spaced else spaced.format(key)
    return line.replace('"$data": {', '"$data": {' + name + json.dumps(row["$data"][key]) + ", ")


def _duplicate_topic(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    return line.replace('"$metadata": {', '"$metadata": {"topic": "sample", ')


def _null_in_list(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    column = "names" if "names" in row["$data"] else "tags"
    row["$data"][column] = [*row["$data"][column], None]
    return json.dumps(row)


def _beyond_int64(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    row["$metadata"]["timestamp"] = rng.randrange(2**63, 2**64)
    return json.dumps(row)


def _count_beyond_int64(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    if "count" not in row["$data"]:
        return None
    row["$data"]["count"] = rng.choice([2**63, 2**64 - 1, -(2**63) - 1, 2**70])
    return json.dumps(row)


def _negative_event_time(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    if row["$metadata"]["topic"] != "bump":
        return None
    row["$metadata"]["timestamp"] = -rng.randrange(1, 2**63)
    return json.dumps(row)


def _event_without_time(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    if row["$metadata"]["topic"] != "bump":
        return None
    del row["$metadata"]["timestamp"]
    return json.dumps(row)


def _not_a_metric(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    if row["$metadata"]["topic"] != "bump":
        return None
    row["$data"]["metrics"] = [*row["$data"]["metrics"], rng.choice([None, 1, "x", [1], True])]
    return json.dumps(row)


def _deep(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    depth = rng.choice([65, 1_000, 10_000, 100_000])
    nest = rng.choice(["[", '{"a":'])
    close = "]" if nest == "[" else "}"
    column = rng.choice(sorted(row["$data"]))
    row["$data"][column] = "@DEEP@"
    return json.dumps(row).replace('"@DEEP@"', nest * depth + "1" + close * depth)


# Per column, values its type does not take.
_WRONG: dict[str, list[Any]] = {
    "flag": [None, 1, "true", []],
    "count": [None, True, 1.5, "1"],
    "value": [None, True, "1.5"],
    "label": [None, 1, True, ["a"]],
    "state": [None, 1, {}],
    "names": [None, "a", [1], {}],
    "name": [None, 2],
    "description": [None, False],
    "status": [None, 3],
    "tags": [None, "a", [True]],
    "metrics": [None, {}, "a"],
}


def _wrong_type(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    column = rng.choice(sorted(row["$data"]))
    row["$data"][column] = rng.choice(_WRONG[column])
    return json.dumps(row)


def _truncated(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    return line[: rng.randrange(1, len(line) - 1)]


def _lone_surrogate(line: str, row: dict[str, Any], rng: random.Random) -> str | None:
    row["$data"][
        rng.choice(["label", "description"] if "label" not in row["$data"] else ["label"])
    ] = "\ud800"
    return json.dumps(row)


MUTATIONS: list[Callable[[str, dict[str, Any], random.Random], str | None]] = [
    _trailing_comma,
    _duplicate_key,
    _duplicate_topic,
    _null_in_list,
    _beyond_int64,
    _count_beyond_int64,
    _negative_event_time,
    _event_without_time,
    _not_a_metric,
    _deep,
    _wrong_type,
    _truncated,
    _lone_surrogate,
]


def hostile_case(tmp: Path, config: Path, seed: int) -> tuple[Path, int, str]:
    """A legal file with one line mutated (or invalid UTF-8 put in it): the file, the
    line's number and the mutation's name."""
    rng = random.Random(seed)
    path = tmp / f"case-{seed}.resim.jsonl"
    write_legal(path, config, rng, rng.randrange(1, 12))
    lines = path.read_bytes().splitlines()
    while True:
        at = rng.randrange(len(lines))
        mutation = rng.choice([*MUTATIONS, None])
        if mutation is None:
            cut = rng.randrange(len(lines[at]))
            lines[at] = (
                lines[at][:cut] + rng.choice([b"\xff", b"\xc3", b"\xed\xa0\x80"]) + lines[at][cut:]
            )
            name = "not UTF-8"
            break
        mutated = mutation(lines[at].decode(), json.loads(lines[at]), rng)
        if mutated is not None:
            lines[at] = mutated.encode("utf-8", "surrogatepass")
            name = mutation.__name__
            break
    path.write_bytes(b"\n".join(lines) + b"\n")
    return path, at + 1, name


def _check_refused(config: MetricsConfig, path: Path, line: int, name: str) -> None:
    with pytest.raises(EmissionsError) as caught:
        _load(config, path)
    assert str(caught.value).startswith(f"{path} line {line}: "), (name, str(caught.value))


def _load(config: MetricsConfig, path: Path) -> None:
    emissions = EmissionsSet(config)
    emissions.add_job(JobMeta(job_id="j"), path)
    emissions.tables()


@pytest.fixture
def config_file(tmp_path: Path) -> Path:
    path = tmp_path / "config.resim.yml"
    path.write_text(CONFIG, encoding="utf-8")
    return path


def test_legal_rows_load_with_the_values_the_emitter_was_given(
    tmp_path: Path, config_file: Path
) -> None:
    config = load_config([config_file])
    for seed in range(3):
        path = tmp_path / f"legal-{seed}.resim.jsonl"
        written = write_legal(path, config_file, random.Random(seed), 40)
        check_loaded(config, path, written)


def test_hostile_rows_are_refused_naming_file_and_line(tmp_path: Path, config_file: Path) -> None:
    config = load_config([config_file])
    for seed in range(40):
        _check_refused(config, *hostile_case(tmp_path, config_file, seed))


@pytest.mark.slow
def test_many_seeds_legal_and_hostile(tmp_path: Path, config_file: Path) -> None:
    config = load_config([config_file])
    for seed in range(100, 130):
        path = tmp_path / f"legal-{seed}.resim.jsonl"
        written = write_legal(path, config_file, random.Random(seed), 200)
        check_loaded(config, path, written)
    for seed in range(1000, 1600):
        _check_refused(config, *hostile_case(tmp_path, config_file, seed))


# Job folder spoilers: each makes one job of a batch unreadable; the refusal names `path`.
def _as_folder(path: Path) -> None:
    path.unlink(missing_ok=True)
    path.mkdir()


def _as_loop(path: Path) -> None:
    path.unlink(missing_ok=True)
    path.symlink_to(path.name)


def _as_fifo(path: Path) -> None:
    path.unlink(missing_ok=True)
    os.mkfifo(path)


def _as_dangling(path: Path) -> None:
    path.unlink(missing_ok=True)
    path.symlink_to(path.with_name("nowhere"))


def _as_deep(path: Path) -> None:
    path.write_text("[" * 10_000 + "]" * 10_000)


def _as_bad_json(path: Path) -> None:
    path.write_text('{"job_id": "x",}')


SPOILERS = [_as_folder, _as_loop, _as_fifo, _as_dangling, _as_deep, _as_bad_json]


def spoilt_batch(tmp: Path, seed: int) -> tuple[Path, Path]:
    """A batch folder (job folders and SDK files) with one thing spoilt, and that thing."""
    rng = random.Random(seed)
    batch = tmp / f"batch-{seed}"
    batch.mkdir()
    line = '{"$metadata": {"topic": "sample"}, "$data": ' + json.dumps(_sample(rng)) + "}\n"
    places = []
    for k in range(rng.randrange(1, 4)):
        (batch / f"job-{k}").mkdir()
        (batch / f"job-{k}" / "emissions.resim.jsonl").write_text(line)
        (batch / f"job-{k}" / "job.json").write_text(json.dumps({"job_id": f"id-{k}"}))
        places += [batch / f"job-{k}" / "emissions.resim.jsonl", batch / f"job-{k}" / "job.json"]
    for k in range(rng.randrange(0, 3)):
        (batch / f"emissions_sdk-{k}.resim.jsonl").write_text(line)
        places.append(batch / f"emissions_sdk-{k}.resim.jsonl")
    place = rng.choice(places)
    spoilers = SPOILERS if place.name == "job.json" else SPOILERS[:4]
    rng.choice(spoilers)(place)
    return batch, place


def test_spoilt_job_folders_are_refused_naming_the_path(tmp_path: Path) -> None:
    for seed in range(24):
        batch, place = spoilt_batch(tmp_path, seed)
        with pytest.raises(EmissionsError) as caught:
            find_jobs([batch])
        assert str(caught.value).startswith(str(place)), str(caught.value)


def _run_eval(
    config: Path, emissions: Path, out: Path, level: str
) -> subprocess.CompletedProcess[str]:
    command = [str(Path(sys.executable).with_name("stook")), "metrics-config", "eval", str(config)]
    command += ["--emissions", str(emissions), "--level", level, "--outputs", str(out)]
    env = {**os.environ, "STOOK_LOG_FORMAT": "console"}
    return subprocess.run(command, capture_output=True, text=True, timeout=60, env=env, check=False)


@pytest.mark.slow
def test_whole_processes_refuse_with_a_documented_code_in_time(
    tmp_path: Path, config_file: Path
) -> None:
    for seed in range(12):
        path, line, name = hostile_case(tmp_path, config_file, 5000 + seed)
        done = _run_eval(config_file, path, tmp_path / f"out-{seed}", "test")
        assert done.returncode == 4, (name, done.stderr)
        assert f"{path} line {line}: " in done.stderr, (name, done.stderr)
        assert "Traceback" not in done.stderr
        assert not (tmp_path / f"out-{seed}").exists()
    for seed in range(6):
        batch, place = spoilt_batch(tmp_path, 7000 + seed)
        done = _run_eval(config_file, batch, tmp_path / f"batch-out-{seed}", "batch")
        assert done.returncode == 2, done.stderr
        assert str(place) in done.stderr
        assert "Traceback" not in done.stderr


@pytest.mark.slow
def test_legal_outputs_are_byte_identical_run_to_run(tmp_path: Path, config_file: Path) -> None:
    path = tmp_path / "legal.resim.jsonl"
    write_legal(path, config_file, random.Random(7), 300)
    outputs = []
    for run in range(2):
        done = _run_eval(config_file, path, tmp_path / f"out-{run}", "test")
        assert done.returncode == 0, done.stderr
        outputs.append((tmp_path / f"out-{run}" / "metrics.binproto").read_bytes())
    assert outputs[0] == outputs[1]
