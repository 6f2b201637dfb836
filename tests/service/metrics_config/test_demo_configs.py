"""ReSim's published demo configs (resim-open-core's config and mujoco, signalflag
1.8.0's session) evaluated at every level they define, over emissions ReSim's Emitter
wrote: every metric of the level present under its configured name, none an error,
each in its set's order, valid to ReSim's own validator, the same bytes every run."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from resim.metrics.proto import metrics_pb2 as resim_pb
from resim.metrics.proto.validate_metrics_proto import validate_job_metrics as resim_validate

from stook.sdk import (
    BarChartMetric,
    HistogramMetric,
    ImageMetric,
    JobMetricsView,
    LinePlotMetric,
    PlotlyMetric,
    TextMetric,
    read_job_metrics,
    validate_job_metrics,
)
from stook.service.cli._main import run_cli
from stook.service.metrics_config import LEVELS, load_config
from tests.service.metrics_config.demo_emissions import Demo, demo, emit_demo_job

JOBS = 3


def _demos() -> list[object]:
    found: list[object] = [
        demo("resim.demo", "config.resim.yml"),
        demo("resim.demo", "mujoco.resim.yml"),
    ]
    # signalflag 1.8.0 adds session.resim.yml. It is no dev dependency: its wheel also
    # installs a `resim` shim that reroutes resim.sdk and resim.demo to itself, which would
    # replace resim-open-core, the oracle every other test reads. Install it apart (its
    # `resim/` folder left out) and put it on PYTHONPATH to run these.
    try:
        found.append(demo("signalflag.demo", "session.resim.yml"))
    except ModuleNotFoundError:
        found.append(pytest.param(None, marks=pytest.mark.skip(reason="signalflag not installed")))
    return found


def _meta(k: int) -> dict[str, str]:
    return {
        "job_id": f"00000000-0000-4000-8000-00000000000{k}",
        "batch_id": f"00000000-0000-4000-8000-0000000000b{k % 2}",
        "project_id": "00000000-0000-4000-8000-0000000000aa",
        "experience_name": f"experience-{k}",
        "build_version": f"1.{k % 2}",
        "job_conflated_status": ("PASSED", "BLOCKER", "WARNING")[k],
    }


@pytest.fixture
def jobs(tmp_path: Path, request: pytest.FixtureRequest) -> Path:
    chosen: Demo = request.node.callspec.params["chosen"]
    folder = tmp_path / "jobs"
    for k in range(JOBS):
        emit_demo_job(folder / f"job-{k}", chosen.config, k, meta=_meta(k))
    return folder


def _eval(chosen: Demo, emissions: Path, level: str, out: Path) -> tuple[bytes, JobMetricsView]:
    argv = ["metrics-config", "eval", str(chosen.config), "--templates", str(chosen.templates)]
    argv += ["--emissions", str(emissions), "--level", level, "--outputs", str(out)]
    assert run_cli(argv) == 0
    raw = (out / "metrics.binproto").read_bytes()
    view = read_job_metrics(raw)
    validate_job_metrics(view.raw)
    theirs = resim_pb.JobMetrics()
    theirs.ParseFromString(raw)
    resim_validate(theirs)
    return raw, view


@pytest.mark.parametrize("chosen", _demos(), ids=lambda d: getattr(d, "name", "signalflag"))
def test_every_level_of_the_demo_config_evaluates(
    tmp_path: Path, chosen: Demo, jobs: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = load_config([chosen.config], chosen.templates)
    for level in LEVELS:
        expected = [m.name for m in config.metrics_for(level)]
        if not expected:
            continue
        emissions = jobs / "job-0" / "emissions.resim.jsonl" if level == "test" else jobs
        raw, view = _eval(chosen, emissions, level, tmp_path / level)
        assert capsys.readouterr().err == ""  # no metric failed
        metrics = [m for m in view.metrics if not m.event_metric]
        assert sorted(m.name for m in metrics) == sorted(expected), level
        for metric in metrics:
            assert ("error", "ERROR") not in metric.tags
            assert ("error", "RENDER_ERROR") not in metric.tags
            assert ("no_data", "true") not in metric.tags
        assert [m.order for m in metrics] == [float(i) for i in range(len(metrics))]
        again, _ = _eval(chosen, emissions, level, tmp_path / f"{level}-again")
        assert again == raw


def test_mujoco_keeps_its_names_links_and_groups(tmp_path: Path) -> None:
    chosen = demo("resim.demo", "mujoco.resim.yml")
    for k in range(JOBS):
        emit_demo_job(tmp_path / "jobs" / f"job-{k}", chosen.config, k, meta=_meta(k))
    _, batch = _eval(chosen, tmp_path / "jobs", "batch", tmp_path / "batch")
    # 'Sum Reward' AS group_name: the groups are inside the one metric, which keeps its name.
    reward = batch.metric("Reward Distribution", HistogramMetric)
    assert not [m.name for m in batch.metrics if m.name.startswith("Reward Distribution (")]
    assert reward.values_data is not None
    assert [g for g, _ in reward.values_data.labelled()] == ["Sum Reward"] * JOBS
    assert reward.x_axis_name == "Sum Reward"

    _, board = _eval(chosen, tmp_path / "jobs", "dashboard", tmp_path / "board")
    outcomes = board.metric("Test Outcomes by Build Version", BarChartMetric)
    # ORDER BY build_version, status: each group where it first appears
    assert outcomes.legend == ("PASSED", "WARNING", "BLOCKER")
    links = json.loads(dict(outcomes.view.tags)["link_paths"])
    project = _meta(0)["project_id"]
    assert links["PASSED"] == {"1.0": f"/projects/{project}/batches/{_meta(0)['batch_id']}"}
    assert set(links) == {"BLOCKER", "PASSED", "WARNING"}


def test_session_renders_text_scalars_and_template_settings(tmp_path: Path) -> None:
    pytest.importorskip("signalflag")
    chosen = demo("signalflag.demo", "session.resim.yml")
    emissions = emit_demo_job(tmp_path / "job", chosen.config, 0)
    _, view = _eval(chosen, emissions, "test", tmp_path / "out")

    # '00:00:07': a scalar of text is shown as that text.
    duration = view.metric("session_duration", TextMetric)
    assert duration.text == "00:00:07"
    assert ("template", "scalar") in duration.view.tags

    # xaxis/yaxis labels over the aliases (x, y); the settings ride along as a tag.
    bar = view.metric("mean_speed_per_mission", BarChartMetric)
    assert (bar.x_axis_name, bar.y_axis_name) == ("Mission", "Mean speed while moving (m/s)")
    line = view.metric("mission0_path_with_gnss", LinePlotMetric)
    assert line.legend == ("GNSS fix", "odometry")
    settings = json.loads(dict(line.view.tags)["template_settings"])
    assert settings["series"][0] == {"group_name": "odometry", "color": "#AE84DE"}
    coverage = view.metric("gnss_coverage_per_mission", BarChartMetric)
    assert json.loads(dict(coverage.view.tags)["template_settings"])["yaxis"]["max"] == 1

    hist = view.metric("speed_distribution", HistogramMetric)
    assert len(hist.buckets) == 40
    assert hist.x_axis_name == "Speed (m/s)"

    (pie,) = view.metric("moving_vs_stopped_time", PlotlyMetric).json["data"]
    assert pie["textinfo"] == "label+percent"

    # every stop and start: an image list of the clips, in the set's first place
    first = min((m for m in view.metrics if m.order is not None), key=lambda m: m.order or 0)
    assert first.name == "movement_summary"
    table = view.metric("mission_summary_table", TextMetric)
    assert table.text.splitlines()[0] == "| category | value |"


def test_a_video_is_an_external_file_tagged_as_a_video(tmp_path: Path) -> None:
    chosen = demo("resim.demo", "config.resim.yml")
    emissions = emit_demo_job(tmp_path / "job", chosen.config, 0)
    _, view = _eval(chosen, emissions, "test", tmp_path / "out")
    video = view.metric("Camera Feed", ImageMetric)
    assert ("template", "video") in video.view.tags
    assert video.image_data is not None
    assert video.image_data.external_path == "camera_video_filename_0.mp4"
    assert (tmp_path / "out" / "camera_video_filename_0.mp4").is_file()
    frame = view.metric("Camera Frame", ImageMetric)
    assert not any(key == "template" for key, _ in frame.view.tags)
