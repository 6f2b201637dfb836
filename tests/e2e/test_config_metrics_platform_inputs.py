"""What the platform gives config-defined metrics in batch and report mode, from the API:
the experience's custom fields and the build's creation time in `metadata`, the batch's
own metrics set, and a dashboard's `day_range`; each looked up once, on the run's client,
counted in its traffic; what the API no longer has handled as documented."""

from __future__ import annotations

import statistics
from collections import Counter
from datetime import timedelta
from pathlib import Path

import pytest

from stook.emulator import EMISSIONS_CONFIG_YAML, write_emissions_config
from stook.emulator._world import JobSpec
from stook.sdk import BarChartMetric
from stook.service.cli import run_cli
from stook.service.modes import (
    BatchInputs,
    ConfigError,
    ReportInputs,
    detect,
    load,
    run_batch,
    run_report,
)
from stook.testing import emulated_batch, emulated_report
from tests.e2e.support import (
    OUTPUT_NAME,
    EmulatorThread,
    by_name,
    config,
    outputs_left,
    read_output,
    text_of,
    write_batch_inputs,
)
from tests.failures import failure_lines, json_events

pytestmark = pytest.mark.usefixtures("isolated")

# Batch metrics over `metadata` (the real configs' way: a value by its key's position),
# and a set holding one of them.
_METADATA_METRICS = """\
  Lighting per experience:
    type: batch
    query_string: |
      SELECT experience_name AS "Experience",
             custom_field_values[array_position(custom_field_keys, 'Lighting')] AS "Lighting",
             cardinality(filter(custom_field_keys, k -> k = 'Sensors')) AS "Sensors",
             array_join(custom_field_keys, '+') || '=' || array_join(custom_field_values, '+')
                 AS "Fields",
             COUNT(*) AS "Jobs"
      FROM metadata
      WHERE contains(custom_field_keys, 'Lighting')
      GROUP BY 1, 2, 3, 4
      ORDER BY 1
    template_type: system
    template: table
  Jobs without custom fields:
    type: batch
    query_string: SELECT COUNT_IF(cardinality(custom_field_keys) = 0) AS value FROM metadata
    template_type: system
    template: scalar
    skip_if_no_data: false
  Newest build created:
    type: batch
    query_string: SELECT to_unixtime(MAX(build_creation_timestamp)) AS value FROM metadata
    template_type: system
    template: scalar
"""
_METADATA_SET = """\
  lighting:
    metrics:
      - Lighting per experience
"""
CONFIG = EMISSIONS_CONFIG_YAML.replace(
    "\nmetrics sets:\n", "\n" + _METADATA_METRICS + "\nmetrics sets:\n" + _METADATA_SET, 1
)


def _toml(folder: Path, yaml_text: str = CONFIG, extra: str = "") -> Path:
    write_emissions_config(folder / ".resim" / "metrics", yaml_text)
    toml = folder / "stook.toml"
    toml.write_text(
        "[batch]\ndefaults = false\n\n[report]\ndefaults = false\n\n"
        '[metrics_config]\npaths = [".resim/metrics/config.resim.yml"]\n' + extra
    )
    return toml


def _batch(inputs: Path) -> BatchInputs:
    found = detect(inputs)
    assert isinstance(found, BatchInputs)
    return found


def _expected_rows(jobs: list[JobSpec], missing: tuple[int, ...] = ()) -> list[str]:
    """The lighting table's rows, from the emulator's experiences."""
    rows: Counter[tuple[str, str, int, str]] = Counter()
    for job in jobs:
        experience = job.experience
        fields = {f.name: f.values for f in experience.custom_fields}
        if experience.index in missing or "Lighting" not in fields:
            continue
        keys = [f.name for f in experience.custom_fields for _ in f.values]
        values = [v for f in experience.custom_fields for v in f.values]
        pairs = "+".join(keys) + "=" + "+".join(values)
        rows[(experience.name, fields["Lighting"][0], len(fields["Sensors"]), pairs)] += 1
    return [
        f"| {n} | {light} | {s} | {listed} | {c} |" for (n, light, s, listed), c in rows.items()
    ]


def _without_fields(jobs: list[JobSpec], missing: tuple[int, ...] = ()) -> int:
    return sum(1 for j in jobs if not j.experience.custom_fields or j.experience.index in missing)


async def test_custom_fields_and_the_build_time_reach_metadata_each_looked_up_once(
    tmp_path: Path,
) -> None:
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    toml = _toml(tmp_path)
    # 12 jobs over 5 experiences (one of them without custom fields), one build.
    async with emulated_batch(inputs, jobs_per_batch=12, experiences=5, seed=3) as emu:
        batch = _batch(inputs)
        before = emu.stats.requests["api"] + emu.stats.requests["storage"]
        result = await run_batch(batch, load(toml), outputs)
        served = emu.stats.requests["api"] + emu.stats.requests["storage"] - before
        endpoints = emu.stats.endpoints
        jobs = list(emu.dataset.jobs(emu.batch_id))
        spec = emu.dataset.batch(emu.batch_id)
        assert spec is not None
        build = emu.dataset.builds[spec.build_id]
    view = read_output(result.output)
    metrics = by_name(view)
    table = text_of(metrics["Lighting per experience"])
    expected = _expected_rows(jobs)
    assert len(expected) == 4  # every experience with custom fields, a sensor list of 2
    for row in expected:
        assert row in table
    assert "+Sensors+Sensors+" in table  # a field of two values: its key twice
    assert metrics["Jobs without custom fields"].value == _without_fields(jobs) > 0
    assert metrics["Newest build created"].value == build.created.timestamp()
    # Each distinct experience and build once, on the run's client, in its traffic.
    assert endpoints["api:get_experience"] == len({j.experience.id for j in jobs}) == 5
    assert endpoints["api:list_experience_tags"] == 5
    assert endpoints["api:get_build"] == 1
    assert endpoints["api:get_batch"] == 1
    assert result.requests == served


async def test_spec_quirks_change_no_custom_field(tmp_path: Path) -> None:
    # Go's omitempty: an experience without custom fields answers without the key.
    written = []
    for quirks in (False, True):
        folder = tmp_path / str(quirks)
        toml = _toml(folder)
        async with emulated_batch(
            folder / "inputs", jobs_per_batch=10, experiences=5, seed=3, spec_quirks=quirks
        ):
            batch = _batch(folder / "inputs")
            result = await run_batch(batch, load(toml), folder / "out")
        metrics = by_name(read_output(result.output))
        written.append(
            (
                text_of(metrics["Lighting per experience"]),
                metrics["Jobs without custom fields"].value,
            )
        )
    assert written[0] == written[1]


def test_a_missing_experience_gives_its_jobs_no_custom_fields_said_once(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    # Experience 1 is gone (404) while 3 of the batch's jobs still name it.
    missing = (1,)
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    toml = _toml(tmp_path)
    emulator = config(jobs_per_batch=12, experiences=4, seed=3, missing_experiences=missing)
    with EmulatorThread(emulator) as emu:
        write_batch_inputs(inputs, emu)
        argv = ["run", "--inputs", str(inputs), "--outputs", str(outputs), "--config", str(toml)]
        code = run_cli([*argv, "--log-format", "json"])
        jobs = list(emu.dataset.jobs(emu.batch_id))
        asked = emu.stats.endpoints["api:get_experience"]
    err = capsys.readouterr().err
    assert code == 0, err
    gone = [j for j in jobs if j.experience.index in missing]
    assert len(gone) == 3
    warned = [e for e in json_events(err) if e.get("event", "").startswith("experience not found")]
    assert [e["experience_id"] for e in warned] == [str(gone[0].experience.id)]
    assert asked == 4  # asked once, not once per job
    metrics = by_name(read_output(outputs / OUTPUT_NAME))
    table = text_of(metrics["Lighting per experience"])
    for row in _expected_rows(jobs, missing):
        assert row in table
    assert gone[0].experience.name not in table
    assert metrics["Jobs without custom fields"].value == _without_fields(jobs, missing)


async def test_batch_mode_evaluates_the_batchs_own_metrics_set(tmp_path: Path) -> None:
    # Launched with "nightly"; stook.toml names no set.
    toml = _toml(tmp_path / "own")
    inputs = tmp_path / "own" / "inputs"
    async with emulated_batch(inputs, jobs_per_batch=8, seed=4, metrics_set_name="nightly") as emu:
        result = await run_batch(_batch(inputs), load(toml), tmp_path / "own" / "out")
        assert emu.stats.endpoints["api:get_batch"] == 1  # the metadata rows' lookup
    names = set(by_name(read_output(result.output)))
    assert {"Mean localization error", "Job outcomes", "Jobs with collisions"} <= names
    assert not names & {"Total distance driven", "Lighting per experience"}

    # stook.toml's own set wins over the batch's.
    toml = _toml(tmp_path / "named", extra='metrics_set = "lighting"\n')
    inputs = tmp_path / "named" / "inputs"
    async with emulated_batch(inputs, jobs_per_batch=8, seed=4, metrics_set_name="nightly"):
        result = await run_batch(_batch(inputs), load(toml), tmp_path / "named" / "out")
    names = set(by_name(read_output(result.output)))
    assert "Lighting per experience" in names
    assert "Mean localization error" not in names

    # Without a set on either side: every batch metric.
    toml = _toml(tmp_path / "none")
    inputs = tmp_path / "none" / "inputs"
    async with emulated_batch(inputs, jobs_per_batch=8, seed=4):
        result = await run_batch(_batch(inputs), load(toml), tmp_path / "none" / "out")
    names = set(by_name(read_output(result.output)))
    assert {"Total distance driven", "Lighting per experience", "Job outcomes"} <= names


def test_a_batch_set_the_config_lacks_is_one_line_and_exit_2(
    capsys: pytest.CaptureFixture[str], tmp_path: Path
) -> None:
    inputs, outputs = tmp_path / "inputs", tmp_path / "outputs"
    toml = _toml(tmp_path)
    with EmulatorThread(config(jobs_per_batch=4, seed=4, metrics_set_name="weekly")) as emu:
        write_batch_inputs(inputs, emu)
        argv = ["run", "--inputs", str(inputs), "--outputs", str(outputs), "--config", str(toml)]
        code = run_cli(argv)
    lines = failure_lines(capsys.readouterr().err)
    assert code == 2
    assert lines == [
        f"stook: error: batch {emu.batch_id} was launched with metrics set 'weekly', which "
        f"the config of {toml} [metrics_config] lacks (known: lighting, nightly, trends); "
        "name one with [metrics_config] metrics_set"
    ]
    assert outputs_left(outputs) == []


async def test_report_mode_counts_only_the_batches_within_the_day_range(
    tmp_path: Path,
) -> None:
    # Four report batches a day apart; the report ends 12 hours after the last one, so
    # a 2-day range keeps the last two.
    two_days = CONFIG.replace("day_range: 90", "day_range: 2", 1)
    results = {}
    for name, yaml_text in (("90", CONFIG), ("2", two_days)):
        folder = tmp_path / name
        toml = _toml(folder, yaml_text)
        async with emulated_report(
            folder / "inputs", report_batches=4, report_jobs_per_batch=5, decoy_batches=0, seed=5
        ) as emu:
            inputs = detect(folder / "inputs")
            assert isinstance(inputs, ReportInputs)
            before = emu.stats.requests["api"] + emu.stats.requests["storage"]
            result = await run_report(inputs, load(toml), folder / "out")
            served = emu.stats.requests["api"] + emu.stats.requests["storage"] - before
            logs = emu.stats.endpoints["api:list_job_logs"]
            batches = emu.dataset.report_batches()
            end = emu.dataset.report.end
            errors: dict[str, list[float]] = {}
            since = end - timedelta(days=int(name))
            for batch in batches:
                if batch.created < since:
                    continue
                version = emu.dataset.builds[batch.build_id].version
                for _job, rows in emu.dataset.emitted_rows(batch.id):
                    errors.setdefault(version, []).extend(
                        r.data["error"] for r in rows or () if r.topic == "localization"
                    )
        view = read_output(result.output)
        bars: dict[str, float] = {}
        for values in view.metric("Mean localization error by build", BarChartMetric).values_data:
            bars.update(values.labelled())
        results[name] = (bars, logs)
        assert bars == pytest.approx({v: statistics.fmean(e) for v, e in errors.items()})
        assert result.requests == served
        # Every batch of the report still counts for the report's own metrics.
        assert result.counts["batches"] == 4
    assert len(results["90"][0]) == 4
    assert results["90"][1] == 4 * 5
    assert len(results["2"][0]) == 2
    assert results["2"][1] == 2 * 5


async def test_dashboards_of_one_set_over_different_day_ranges_are_refused_at_once(
    tmp_path: Path,
) -> None:
    two = CONFIG.replace(
        "    day_range: 90\n",
        "    day_range: 90\n  Weekly trends:\n    metrics_set: trends\n    day_range: 7\n",
        1,
    )
    toml = _toml(tmp_path, two)
    async with emulated_report(tmp_path / "inputs", report_batches=2, seed=5) as emu:
        inputs = detect(tmp_path / "inputs")
        assert isinstance(inputs, ReportInputs)
        with pytest.raises(ConfigError) as raised:
            await run_report(inputs, load(toml), tmp_path / "out")
        assert emu.stats.requests["api"] == 0
    assert str(raised.value) == (
        f"{toml}: [metrics_config]: dashboards 'Weekly trends' (7 days) and 'Nightly trends' "
        "(90 days) show the dashboard metrics over different day ranges, so which one the "
        "report stands for cannot be told"
    )


@pytest.mark.slow
async def test_a_sharded_batch_takes_the_batchs_set_and_custom_fields_as_a_local_run(
    tmp_path: Path,
) -> None:
    from stook.service.modes import EngineSettings

    written: list[bytes] = []
    for engine in (EngineSettings(), EngineSettings("processes", workers=2, shards=3)):
        folder = tmp_path / engine.kind
        toml = _toml(
            folder,
            CONFIG.replace(
                "      - Job outcomes\n",
                "      - Job outcomes\n      - Lighting per experience\n",
                1,
            ),
        )
        async with emulated_batch(
            folder / "inputs", jobs_per_batch=12, experiences=5, seed=3, metrics_set_name="nightly"
        ) as emu:
            result = await run_batch(
                _batch(folder / "inputs"), load(toml), folder / "out", engine=engine
            )
            assert emu.stats.endpoints["api:get_experience"] == 5
        names = set(by_name(read_output(result.output)))
        assert "Lighting per experience" in names
        assert "Total distance driven" not in names
        written.append(result.output.read_bytes())
    assert written[0] == written[1]
