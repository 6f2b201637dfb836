"""`stook demo`'s config-defined metrics: the emulated project's `config.resim.yml` over
what its batch's tests emitted.

The same batch as the demo's batch mode, run with `[metrics_config]` instead of stook's
own aggregations: each job's EMISSIONS_LOG is downloaded and the config's `type: batch`
metrics (SQL over the emitted topics) are written to metrics.binproto, with a preview.

Then the same jobs are downloaded, through stook's API client, into `runs/` beside the
config as the offline layout `stook metrics-config eval --emissions` reads (a folder per
job: its emissions.resim.jsonl and job.json, its row of the `metadata` table as batch mode
fills it), and the two commands that evaluate it on this machine are printed.
"""

from __future__ import annotations

import asyncio
import json
import shlex
import time
import uuid
from collections.abc import Callable
from pathlib import Path

from stook.emulator import EMISSIONS_FILE, write_emissions_config
from stook.sdk import JobMetricsView, MetricStatus, read_job_metrics
from stook.service.api import ApiClient, Job
from stook.service.fetch import fetch_emissions
from stook.service.modes import BatchInputs, detect, for_stream, load, run_batch, run_on_event_loop
from stook.testing._frames import camera_frame_png

CONFIG_TOML = """\
# Only the config-defined metrics: stook's own batch metrics are off.
[batch]
defaults = false

[output]
summary = false

[metrics_config]
paths = [".resim/metrics/config.resim.yml"]
"""
# The config metric the demo shows, and its SQL's gist.
SHOWN = "Mean localization error"


def write_attached_frames(view: JobMetricsView, folder: Path) -> list[Path]:
    """The camera frames the output's image metrics name, beside it. The emulated tests
    attach no real files, and batch mode names an attached file without downloading it
    (the platform keeps the job's files): the demo draws one in its place, so that the
    preview shows an image where a user's would show theirs."""
    written: list[Path] = []
    for data in view.data:
        path = data.external_path
        if path is None or not path.lower().endswith(".png"):
            continue
        target = (folder / path).resolve()
        if not target.is_relative_to(folder.resolve()):
            continue
        target.parent.mkdir(parents=True, exist_ok=True)
        target.write_bytes(camera_frame_png(hue=len(written) * 40))
        written.append(target)
    return written


def run_config_metrics_demo(
    inputs: Path, output: Path, *, print_output: Callable[[Path], int]
) -> int:
    """Runs batch mode on `inputs` with the emulated project's config; returns how many
    outputs were invalid (0 or 1)."""
    folder = output / "metrics-config"
    config_file = write_emissions_config(folder / ".resim" / "metrics")
    toml = folder / "stook.toml"
    toml.write_text(CONFIG_TOML, encoding="utf-8")
    print(f"\n== config-defined metrics: {config_file.name} over the batch's emissions ==")
    batch = detect(inputs)
    assert isinstance(batch, BatchInputs)
    started = time.perf_counter()
    result = run_on_event_loop(
        run_batch(batch, load(toml), folder, progress=for_stream(label="jobs"))
    )
    seconds = time.perf_counter() - started
    view = read_job_metrics(result.output.read_bytes(), source=str(result.output))
    write_attached_frames(view, result.output.parent)
    invalid = print_output(result.output)
    shown = next(m for m in view.metrics if m.name == SHOWN)
    status = shown.status.name if isinstance(shown.status, MetricStatus) else "?"
    print(
        f"  {SHOWN} (SELECT AVG(error) FROM localization): {shown.value:.4f} {shown.unit}, "
        f"{status}; {len(view.metrics)} config metrics from {result.outcome.jobs_listed} jobs' "
        f"emissions logs, {seconds:.2f} s"
    )
    runs = folder / "runs"
    started = time.perf_counter()
    jobs = run_on_event_loop(download_runs(batch, runs))
    print(
        f"  the same {jobs} jobs downloaded for offline use (a folder per job: its emissions "
        f"and job.json) into {runs}, {time.perf_counter() - started:.2f} s;"
    )
    print("  evaluate them on this machine:")
    for command in offline_commands(config_file, runs, folder / "offline"):
        print("    " + shlex.join(command))
    return invalid


def offline_commands(config: Path, runs: Path, output: Path) -> list[list[str]]:
    """`stook metrics-config check` of the config, and `eval` of its batch metrics over
    the downloaded jobs into `output`."""
    return [
        ["stook", "metrics-config", "check", str(config)],
        ["stook", "metrics-config", "eval", str(config), "--emissions", str(runs),
         "--level", "batch", "--preview", "-o", str(output)],
    ]  # fmt: skip


async def download_runs(batch: BatchInputs, runs: Path) -> int:
    """Write each job of the batch into `runs/<position>-<job ID>/`: its emissions log as
    emissions.resim.jsonl and its metadata row as job.json, filled from the API as batch
    mode fills it; returns how many jobs."""
    access, project = batch.access, batch.access.project_id
    async with ApiClient(access.api_url, access.token) as api:
        listed = await api.get_batch(project, batch.batch_id)
        jobs = [job async for job in api.list_jobs(project, batch.batch_id)]
        builds = sorted({b for job in jobs if (b := job.build_id or listed.build_id)})
        experiences = sorted({job.experience_id for job in jobs if job.experience_id})
        versions = [(await api.get_build(project, b)).version for b in builds]
        branches = {b.branch_id: b.name async for b in api.list_branches(project)}
        tags = await asyncio.gather(
            *(_tag_names(api, project, experience) for experience in experiences)
        )
        version_of = dict(zip(builds, versions, strict=True))
        tags_of = dict(zip(experiences, tags, strict=True))
        frame = camera_frame_png()
        order = {job.job_id: index for index, job in enumerate(jobs)}
        width = len(str(len(jobs)))

        def write(job: Job, emitted: bytes | None) -> None:
            build = job.build_id or listed.build_id
            meta = {
                "job_id": str(job.job_id),
                "batch_id": str(batch.batch_id),
                "project_id": str(project),
                "experience_id": _text(job.experience_id),
                "experience_name": job.experience_name,
                "build_id": _text(build),
                "build_version": None if build is None else version_of[build],
                "batch_name": listed.friendly_name,
                "job_status": _text(job.job_status),
                "job_conflated_status": _text(job.conflated_status),
                "branch": None if listed.branch_id is None else branches.get(listed.branch_id),
                "tags": list(tags_of.get(job.experience_id, ())) if job.experience_id else [],
            }
            # Named in listing order: eval reads the folders sorted, and adds the jobs' rows
            # in the order batch mode does (a float sum's last bits depend on it).
            folder = runs / f"{order[job.job_id]:0{width}d}-{job.job_id}"
            folder.mkdir(parents=True, exist_ok=True)
            (folder / "job.json").write_text(json.dumps(meta, indent=2) + "\n", encoding="utf-8")
            # A job that uploaded no emissions log emitted nothing: an empty file, so that
            # its metadata row (which "Job outcomes" counts) is there, as in batch mode.
            (folder / EMISSIONS_FILE).write_bytes(emitted or b"")
            # The camera frame each emitted `camera` row names, as the test would have
            # written it beside its emissions (the emulator serves no such file).
            for name in _snapshots(emitted or b""):
                (folder / name).write_bytes(frame)

        await fetch_emissions(
            api,
            project,
            jobs,
            ids_of=lambda job: (batch.batch_id, job.job_id),
            on_job=write,
            workers=16,
        )
    return len(jobs)


async def _tag_names(api: ApiClient, project: uuid.UUID, experience: uuid.UUID) -> tuple[str, ...]:
    return tuple(sorted([tag.name async for tag in api.list_experience_tags(project, experience)]))


def _snapshots(emitted: bytes) -> list[str]:
    names = []
    for line in emitted.splitlines():
        row = json.loads(line) if line.strip() else {}
        if row.get("$metadata", {}).get("topic") == "camera":
            names.append(row["$data"]["snapshot"])
    return names


def _text(value: object) -> str | None:
    return None if value is None else str(value)
