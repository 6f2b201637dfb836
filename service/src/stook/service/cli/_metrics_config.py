"""`stook metrics-config check|eval`: the platform's config-defined metrics, offline."""

from __future__ import annotations

import argparse
import shutil
import sys
from pathlib import Path
from typing import TYPE_CHECKING, TextIO

if TYPE_CHECKING:
    from collections.abc import Sequence

    from stook.service.metrics_config import Level, MetricsConfig, OfflineJob

DESCRIPTION = """\
Evaluate the platform's config-defined metrics (.resim/metrics/config.resim.yml) on
this machine, with no network: topics' emissions are loaded into tables, each metric's
Trino SQL runs on DuckDB in this process, and the results are drawn as stook metrics.

  check CONFIG...   check the config: YAML, keys, names, metrics sets, templates
                    present, every query parses and binds against the topics' schemas
  eval CONFIG...    run the metrics of one level over emissions; write
                    OUTPUTS/metrics.binproto (and metrics.html with --preview)

Several CONFIG files are merged as the platform does (topics, metrics and metrics sets
disjoint, version equal, other keys: last wins). Custom templates are read from the
templates/ folder beside the first CONFIG, or --templates DIR."""

EPILOG = """\
--emissions PATH: one emissions file (one job), or a folder of jobs: per-job folders,
each holding emissions.resim.jsonl and optionally job.json, and the SDK's own
emissions_<job_id>.resim.jsonl files. job.json's keys (job_id, batch_id, project_id,
experience_id, experience_name, build_id, build_version, batch_name, job_status,
job_conflated_status, branch, tags, custom_field_keys, custom_field_values,
build_creation_timestamp) fill the job's row of the metadata table; absent IDs are
generated from the folder names (stable), other keys are null. Attached files (image,
video metrics) are read from the job's folder and copied beside metrics.binproto.

A metric whose query fails (ERROR) or whose template cannot draw its result
(RENDER_ERROR: a Liquid error, a value the template cannot carry, a missing attached
file) is written under its name as an error, said once on stderr; the others are
written as usual. --strict makes it exit 4 instead, with nothing written.

exit codes:
  0  check: the config is good; eval: metrics.binproto written
  2  a bad config (one line per problem), option or path (a job folder or job.json
     that cannot be read, named)
  4  a bad emissions row (file, line, topic, column), an output that would not
     validate; with --strict, a failing metric (its query's SQL and the engine's
     message, or what its template could not draw)
  5  the output could not be written
Nothing is written unless everything succeeded."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from stook.service.cli._help import HelpFormatter

    parser.description = DESCRIPTION
    parser.epilog = EPILOG
    actions = parser.add_subparsers(dest="action", required=True, metavar="ACTION")
    check = actions.add_parser(
        "check",
        help="check config files (exit 0, or 2 with one line per problem)",
        description="Check config files: YAML, keys, names, metrics sets, templates, and "
        "that every query parses and binds against the topics' schemas.",
        formatter_class=HelpFormatter,
    )
    _add_common(check)
    check.add_argument(
        "--strict", action="store_true", help="unknown keys are errors (exit 2), not warnings"
    )
    run = actions.add_parser(
        "eval",
        help="evaluate one level's metrics over emissions into metrics.binproto",
        description="Run the metrics of one level over emissions and write "
        "OUTPUTS/metrics.binproto atomically (and metrics.html with --preview).",
        epilog=EPILOG,
        formatter_class=HelpFormatter,
    )
    _add_common(run)
    run.add_argument(
        "--emissions",
        type=Path,
        action="append",
        required=True,
        metavar="PATH",
        help="an emissions.resim.jsonl (one job) or a folder of per-job folders; "
        "repeat the flag for more",
    )
    run.add_argument(
        "--level",
        type=_level,
        required=True,
        metavar="{test,batch,dashboard}",
        help="which metrics run: the test's, the batch's or the dashboard's (report "
        "mode's; 'report' is taken for 'dashboard')",
    )
    run.add_argument(
        "--metrics-set", metavar="NAME", help="only this metrics set's metrics (default: all)"
    )
    run.add_argument(
        "-o",
        "--output",
        "--outputs",
        dest="outputs",
        type=Path,
        default=Path("outputs"),
        metavar="DIR",
        help="where metrics.binproto is written (default: ./outputs)",
    )
    run.add_argument(
        "--preview", action="store_true", help="also write DIR/metrics.html (stook preview)"
    )
    run.add_argument(
        "--strict",
        action="store_true",
        help="a failing metric fails the run (exit 4, nothing written) instead of being "
        "written as an error",
    )


_LEVELS = ("test", "batch", "dashboard")


def _level(text: str) -> str:
    """A level as --level names it; report mode's metrics are the dashboard's."""
    level = "dashboard" if text == "report" else text
    if level not in _LEVELS:
        raise argparse.ArgumentTypeError(
            f"invalid choice: {text!r} (choose from {', '.join(map(repr, _LEVELS))})"
        )
    return level


def _add_common(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("configs", type=Path, nargs="+", metavar="CONFIG", help="config.resim.yml")
    parser.add_argument(
        "--templates",
        type=Path,
        metavar="DIR",
        help="custom Liquid templates (default: templates/ beside the first CONFIG)",
    )


def run(args: argparse.Namespace, *, out: TextIO | None = None) -> int:
    out = out or sys.stdout
    if args.action == "check":
        return check(args.configs, args.templates, out=out, strict=args.strict)
    written = evaluate_offline(
        args.configs,
        args.emissions,
        level=args.level,
        metrics_set=args.metrics_set,
        templates=args.templates,
        outputs=args.outputs,
        preview=args.preview,
        strict=args.strict,
    )
    print(written, file=out)
    return 0


def check(configs: list[Path], templates: Path | None, *, out: TextIO, strict: bool = False) -> int:
    from stook.service.metrics_config import MetricsConfigError, check_config, read_config

    # Every problem at once: the usable metrics are bound even when others are faulty.
    config, problems = read_config(configs, templates, strict=strict)
    try:
        problems += check_config(config)
    except MetricsConfigError as exc:
        problems += exc.problems
    for warning in config.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    if problems:
        for problem in problems:
            print(problem, file=sys.stderr)
        return 2
    names = ", ".join(str(c) for c in configs)
    print(f"{names}: {len(config.topics)} topics, {len(config.metrics)} metrics, ok", file=out)
    return 0


def evaluate_offline(
    configs: list[Path],
    emissions: list[Path],
    *,
    level: Level,
    metrics_set: str | None,
    templates: Path | None,
    outputs: Path,
    preview: bool = False,
    strict: bool = False,
) -> Path:
    """Load, evaluate and write; nothing is written unless all of it succeeded. A failing
    metric is written as an error and said on stderr (with `strict`: raised)."""
    from stook.sdk import MetricsWriter, validate_job_metrics
    from stook.service.cli._usage import UsageError
    from stook.service.metrics_config import (
        EmissionsError,
        EmissionsSet,
        evaluate,
        find_jobs,
        stable_id,
    )

    config = _load(configs, templates)
    config.metrics_for(level, metrics_set)  # an unknown set: exit 2 before any work
    try:
        jobs = find_jobs(emissions)
    except EmissionsError as exc:  # a path or a job.json: bad input, before any work
        raise UsageError(str(exc)) from None
    emission_set = EmissionsSet(config)
    for job in jobs:
        emission_set.add_job(job.meta, job.emissions)
    if level == "test" and len(jobs) != 1:
        raise UsageError(f"--level test evaluates one job's emissions, {len(jobs)} were given")
    if level == "test":
        output_id = jobs[0].meta.job_id
    elif level == "batch":
        batches = sorted({j.meta.batch_id or "" for j in jobs})
        one = len(batches) == 1 and batches[0]
        output_id = batches[0] if one else stable_id("batches", ",".join(batches))
    else:
        output_id = stable_id("report", ",".join(sorted(j.meta.job_id for j in jobs)))
    writer = MetricsWriter(_as_uuid(output_id), deterministic=True)
    result = evaluate(
        config,
        emission_set.tables(),
        writer,
        level=level,
        metrics_set=metrics_set,
        strict=strict,
        attached=lambda name: _attached_file(jobs, name) is not None,
    )
    for failure in result.failed:
        print(f"stook: {failure}", file=sys.stderr)
    attached = []
    for name in result.files:
        found = _attached_file(jobs, name)
        if found is None:
            raise EmissionsError(f"attached file {name!r} is in no job's folder")
        attached.append((found, name))
    try:
        outputs.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise UsageError(f"{outputs}: cannot be created ({exc.strerror or exc})") from None
    validate_job_metrics(writer.to_proto())  # before any attached file is copied
    for path, name in attached:
        (outputs / name).parent.mkdir(exist_ok=True)  # a job's file: <job_id>/<file>
        shutil.copyfile(path, outputs / name)
    written = writer.write(outputs / "metrics.binproto")
    if preview:
        from stook.service.preview import PREVIEW_NAME, write_preview

        write_preview([written], written.with_name(PREVIEW_NAME))
    return written


def _attached_file(jobs: Sequence[OfflineJob], name: str) -> Path | None:
    """Where the file a metric names is: `<file>` in any job's folder (the first), or
    `<job_id>/<file>` in that job's."""
    job_id, _, base = name.rpartition("/")
    for job in jobs:
        if (not job_id or job.meta.job_id == job_id) and (job.folder / base).is_file():
            return job.folder / base
    return None


def _load(configs: list[Path], templates: Path | None) -> MetricsConfig:
    """The config, its warnings said on stderr (this command's logging is off until an
    error is said); MetricsConfigError with every problem."""
    from stook.service.metrics_config import MetricsConfigError, read_config

    config, problems = read_config(configs, templates)
    if problems:
        raise MetricsConfigError(problems)
    for warning in config.warnings:
        print(f"warning: {warning}", file=sys.stderr)
    return config


def _as_uuid(text: str) -> str:
    """The output's ID: job.json may name a job or batch by any text, the output needs a
    UUID (one derived from the text, stable, when it is not one)."""
    import uuid

    from stook.service.metrics_config import stable_id

    try:
        return str(uuid.UUID(text))
    except ValueError:
        return stable_id("output", text)
