"""Config-defined metrics in batch mode through `stook run`: each job's metadata row, and,
when something is wrong, one line, the documented exit code, no output, and a bad config
refused before the first request."""

from __future__ import annotations

import json
from collections import Counter
from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.emulator import EMISSIONS_CONFIG_YAML, Emulator, write_emissions_config
from stook.sdk import MetricStatus, PlotlyMetric, TextMetric
from stook.service.cli import run_cli
from tests.e2e.support import (
    OUTPUT_NAME,
    EmulatorThread,
    config,
    outputs_left,
    read_output,
    write_batch_inputs,
)
from tests.failures import failure_lines

pytestmark = pytest.mark.usefixtures("isolated")


@pytest.fixture(scope="module")
def emu() -> Iterator[Emulator]:
    with EmulatorThread(config(jobs_per_batch=12, seed=9, broken_jobs=())) as emulator:
        yield emulator


def _run(
    capsys: pytest.CaptureFixture[str],
    tmp_path: Path,
    emu: Emulator,
    yaml_text: str,
    extra_toml: str = "",
) -> tuple[int, list[str], Path]:
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    write_batch_inputs(inputs, emu)
    write_emissions_config(tmp_path, yaml_text)
    toml = tmp_path / "stook.toml"
    toml.write_text('[metrics_config]\npaths = ["config.resim.yml"]\n' + extra_toml)
    argv = ["run", "--inputs", str(inputs), "--outputs", str(outputs), "--config", str(toml)]
    code = run_cli([*argv, "--log-format", "json"])
    err = capsys.readouterr().err
    assert "Traceback" not in err
    return code, failure_lines(err), outputs


def test_jobs_without_a_log_still_have_their_metadata_row(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    code, _, outputs = _run(capsys, tmp_path, emu, EMISSIONS_CONFIG_YAML)
    assert code == 0
    view = read_output(outputs / OUTPUT_NAME)
    figure = view.metric("Job outcomes", PlotlyMetric).json
    (pie,) = figure["data"]
    shown = dict(zip(pie["labels"], pie["values"], strict=True))
    jobs = emu.dataset.jobs(emu.batch_id)
    assert shown == dict(Counter(j.conflated_status for j in jobs))
    assert any(emu.dataset.job_emissions(emu.batch_id, j.id) is None for j in jobs)


def test_a_bad_config_is_refused_before_the_first_request(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    before = emu.stats.requests["api"]
    broken = EMISSIONS_CONFIG_YAML.replace("template: pie", "template: donut", 1)
    assert broken != EMISSIONS_CONFIG_YAML
    code, lines, outputs = _run(capsys, tmp_path, emu, broken)
    assert code == 2
    assert len(lines) == 1
    assert "config.resim.yml" in lines[0]
    assert emu.stats.requests["api"] == before
    assert outputs_left(outputs) == []


def test_an_unknown_metrics_set_is_refused_before_the_first_request(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    before = emu.stats.requests["api"]
    code, lines, outputs = _run(
        capsys, tmp_path, emu, EMISSIONS_CONFIG_YAML, 'metrics_set = "nightly-typo"\n'
    )
    assert code == 2
    assert lines == [
        f"stook: error: {tmp_path / 'stook.toml'}: [metrics_config] metrics_set "
        "'nightly-typo' is not a metrics set of the config (known: nightly, trends)"
    ]
    assert emu.stats.requests["api"] == before
    assert outputs_left(outputs) == []


def test_a_row_against_its_topics_schema_names_the_job_line_and_column(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    # The config says `error` is a string: every emitted localization row disagrees.
    wrong = EMISSIONS_CONFIG_YAML.replace("      error: float", "      error: string", 1)
    code, lines, outputs = _run(capsys, tmp_path, emu, wrong)
    assert code == 4
    assert len(lines) == 1
    assert "emissions log" in lines[0]
    assert "localization" in lines[0]
    assert "error" in lines[0]
    assert outputs_left(outputs) == []


def test_a_query_that_fails_names_the_metric(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    failing = EMISSIONS_CONFIG_YAML.replace(
        "query_string: SELECT SUM(distance) AS value FROM run_summary",
        "query_string: SELECT SUM(CAST(completed AS DOUBLE) / 0) AS value FROM run_summary x"
        " JOIN run_summary y ON x.distance > 'a'",
        1,
    )
    assert failing != EMISSIONS_CONFIG_YAML
    code, lines, outputs = _run(capsys, tmp_path, emu, failing, "strict = true\n")
    assert code in (2, 4)  # statically detectable or not, it is the query's fault
    assert len(lines) == 1
    assert "Total distance driven" in lines[0]
    assert outputs_left(outputs) == []
    assert json.dumps(lines)  # one plain line each


def test_without_strict_a_failing_query_is_its_metric_marked_error(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    failing = EMISSIONS_CONFIG_YAML.replace(
        "query_string: SELECT SUM(distance) AS value FROM run_summary",
        "query_string: SELECT CAST(MAX(distance) AS VARCHAR) || 'x' / 2 AS value FROM run_summary",
        1,
    )
    assert failing != EMISSIONS_CONFIG_YAML
    code, _, outputs = _run(capsys, tmp_path, emu, failing)
    assert code == 0
    view = read_output(outputs / OUTPUT_NAME)
    failed = view.metric("Total distance driven", TextMetric)
    assert failed.status is MetricStatus.NOT_APPLICABLE
    assert dict(failed.view.tags) == {"error": "ERROR"}
    assert "its query failed" in failed.text
    view.metric("Job outcomes", PlotlyMetric)  # the others are written as usual


def test_each_jobs_metadata_row_is_filled_from_the_listings(
    capsys: pytest.CaptureFixture[str], tmp_path: Path, emu: Emulator
) -> None:
    with_metadata = EMISSIONS_CONFIG_YAML.replace(
        "metrics:\n",
        "metrics:\n"
        "  Metadata rows:\n"
        "    type: batch\n"
        "    query_string: |\n"
        "      SELECT job_id, batch_id, project_id, experience_name, build_version, branch,\n"
        "             job_status, job_conflated_status, ARRAY_JOIN(tags, '+') AS tags\n"
        "      FROM metadata ORDER BY job_id\n"
        "    template_type: system\n"
        "    template: table\n",
        1,
    )
    code, _, outputs = _run(capsys, tmp_path, emu, with_metadata)
    assert code == 0
    text = read_output(outputs / OUTPUT_NAME).metric("Metadata rows", TextMetric).text
    ds = emu.dataset
    batch = ds.batch(emu.batch_id)
    assert batch is not None
    version = ds.builds[batch.build_id].version
    expected = [
        f"| {job.id} | {emu.batch_id} | {emu.project_id} | {job.experience.name} | {version} "
        f"| main | {job.job_status} | {job.conflated_status} "
        f"| {'+'.join(sorted(t.name for t in job.experience.tags))} |"
        for job in sorted(ds.jobs(emu.batch_id), key=lambda j: str(j.id))
    ]
    assert text.splitlines()[2:] == expected
