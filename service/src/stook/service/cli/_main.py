"""The `stook` command: run (the metrics-build entry point), demo, emulate, validate, show.

Only the standard library, the help texts and the signal guard are imported at the top.
Each command imports its modules when `_dispatch` runs it: `stook --help` and `--version`
load none of stook's library, `show` and `validate` only the SDK's reader, and `main`
takes SIGINT and SIGTERM before any of it, so that a signal during those imports still
ends in one line and not a traceback.
"""

from __future__ import annotations

import os
import sys
from typing import TYPE_CHECKING

from stook.service.cli import _help, _signals
from stook.service.cli._emulate_flags import add_emulate_flags
from stook.service.cli._process import ProcessEnd
from stook.service.cli._signals import Interrupted

if TYPE_CHECKING:
    import argparse
    from collections.abc import Callable, Sequence
    from typing import Any

    from stook.service.cli._run import Written
    from stook.service.modes import RecordingProgress


def _add_logging(parser: argparse.ArgumentParser, *, default_level: str = "info") -> None:
    parser.add_argument(
        "--log-level",
        default=os.environ.get("STOOK_LOG_LEVEL", default_level),
        choices=["debug", "info", "warning", "error"],
        help=f"log level (env STOOK_LOG_LEVEL; default {default_level})",
    )
    parser.add_argument(
        "--log-format",
        default=os.environ.get("STOOK_LOG_FORMAT", "auto"),
        choices=["auto", "json", "console"],
        help="JSON lines or console lines; auto: `stook run` logs JSON lines when stderr is "
        "not a terminal (the platform collects them), every other command console lines "
        "(env STOOK_LOG_FORMAT; default auto)",
    )


_DISTRIBUTIONS = ("stook", "stook-sdk", "stook-proto")


def version_text() -> str:
    """``stook 0.1.0 (stook-sdk 0.1.0, stook-proto 0.1.0)``, from the installed metadata."""
    from importlib.metadata import PackageNotFoundError, version

    def of(distribution: str) -> str:
        try:
            return f"{distribution} {version(distribution)}"
        except PackageNotFoundError:
            return f"{distribution} not installed"

    main, *others = (of(d) for d in _DISTRIBUTIONS)
    return f"{main} ({', '.join(others)})"


def _json_logs(command: str, chosen: str) -> bool | None:
    """Whether `command` logs JSON lines for ``--log-format`` `chosen`; None: JSON when
    stderr is not a terminal. Only `stook run` picks by the terminal: inside the platform
    its lines are collected, while the offline commands are read by a person."""
    if chosen in ("json", "console"):
        return chosen == "json"
    return None if command == "run" else False


def build_parser() -> argparse.ArgumentParser:
    """The whole command line: every command with all its arguments."""
    return _build_parser(None)


def _chosen_command(argv: Sequence[str] | None) -> str:
    """The command `argv` names: its first word that is not an option (the top level's
    options, ``--version`` and ``--help``, take no value); "" when there is none."""
    args = sys.argv[1:] if argv is None else argv
    return next((a for a in args if not a.startswith("-")), "")


def _build_parser(only: str | None) -> argparse.ArgumentParser:
    """The command line with only command `only`'s arguments (None: every command's; ""
    or a word that is no command: none, as argparse then prints the top level's help, its
    version or its error).

    Every command is there, so the top level's help and its errors are the same; the
    arguments of the commands not run are left out: adding them all is about 5 % of
    `stook validate`'s instructions.
    """
    import argparse

    class VersionAction(argparse.Action):
        # argparse's own "version" action wants the text up front; reading the metadata
        # only when asked keeps it out of every other command's start-up.
        def __call__(self, parser: argparse.ArgumentParser, *_: object) -> None:
            print(version_text())
            parser.exit()

    parser = _help.ArgumentParser(
        prog="stook",
        description="Fast aggregation of ReSim test, batch and report metrics.",
        formatter_class=_help.HelpFormatter,
    )
    parser.add_argument(
        "--version", action=VersionAction, nargs=0, help="print the versions and exit"
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, (line, description, epilog) in _help.COMMANDS.items():
        command = sub.add_parser(
            name,
            help=line,
            description=description,
            epilog=epilog,
            formatter_class=_help.HelpFormatter,
        )
        if only is None or only == name:
            _ADD_ARGUMENTS[name](command)
    return parser


def _add_run_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "--inputs",
        metavar="DIR",
        help="inputs folder (env STOOK_INPUTS; default /tmp/resim/inputs)",
    )
    parser.add_argument(
        "-o",
        "--output",
        "--outputs",
        dest="outputs",
        metavar="DIR",
        help="outputs folder (env STOOK_OUTPUTS; default /tmp/resim/outputs)",
    )
    parser.add_argument(
        "--config",
        metavar="FILE",
        help="stook.toml (env STOOK_CONFIG; default ./stook.toml if present)",
    )
    parser.add_argument(
        "--allow-missing-jobs",
        type=float,
        metavar="FRACTION",
        help="tolerate up to this share of jobs whose data stays unavailable "
        "(env STOOK_ALLOW_MISSING_JOBS; default 0)",
    )
    parser.add_argument(
        "--preview",
        action="store_true",
        help="also write OUTPUTS/metrics.html, a preview of the output ([output] preview)",
    )
    parser.add_argument(
        "--engine",
        choices=("local", "processes", "ray"),
        help="where the fetch and fold runs: this process, local worker processes or Ray "
        "(replaces [engine] kind)",
    )
    parser.add_argument(
        "--project-id",
        metavar="UUID",
        help="project for batch configs that lack projectID (env STOOK_PROJECT_ID)",
    )
    _add_logging(parser)


def _add_demo_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--jobs", type=int, default=200, help="jobs in the emulated batch")
    parser.add_argument(
        "-o",
        "--output",
        "--outputs",
        dest="output",
        metavar="DIR",
        default="demo-output",
        help="where to write the outputs",
    )
    parser.add_argument("--seed", type=int, default=7, help="the emulated data's random seed")
    _add_logging(parser, default_level="warning")


def _add_emulate_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--jobs", type=int, default=200, help="jobs per batch")
    parser.add_argument("--batches", type=int, default=12, help="batches in the report")
    parser.add_argument("--seed", type=int, default=7, help="the emulated data's random seed")
    parser.add_argument(
        "--latency-ms", type=float, default=0.0, help="added to every answer, milliseconds"
    )
    parser.add_argument(
        "--api-port", type=int, default=0, help="the API's port (default 0: any free port)"
    )
    parser.add_argument(
        "--storage-port",
        type=int,
        default=0,
        help="the object storage's port (default 0: any free port)",
    )
    parser.add_argument(
        "--inputs",
        metavar="DIR",
        help="write batch_metrics_config.json, naming this emulator, into this inputs folder",
    )
    add_emulate_flags(parser)
    parser.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="any other emulator setting (a field of stook.emulator.EmulatorConfig), VALUE "
        "as JSON: --set spec_quirks=true --set fault_5xx=0.05 "
        """--set 'outages=[{"origin": "api", "after_s": 5, "duration_s": 8}]'""",
    )
    _add_logging(parser)


def _add_bench_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--quick", action="store_true", help="small sizes; a smoke test")
    parser.add_argument(
        "-o",
        "--output",
        "--out",
        dest="out",
        metavar="DIR",
        help="where results are written (default docs/benchmarks; --probe: probe-results)",
    )
    parser.add_argument(
        "--engines",
        action="store_true",
        help="only compare [engine] local, processes and ray on one batch (20,000 jobs; "
        "--quick: 2,000)",
    )
    from stook.service.cli._probe_flags import add_probe_flags

    add_probe_flags(parser)
    _add_logging(parser, default_level="warning")


# `validate` and `show` take the file's name as given.
_FILE_HELP = "a metrics.binproto (a JobMetrics message, from stook or ReSim's own writer)"


def _add_validate_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help=_FILE_HELP)


def _add_show_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("file", help=_FILE_HELP)
    parser.add_argument(
        "--full",
        action="store_true",
        help="print TEXT metrics whole, below the table, and names untruncated",
    )


def _add_preview_arguments(parser: argparse.ArgumentParser) -> None:
    from pathlib import Path

    parser.add_argument(
        "files",
        type=Path,
        nargs="+",
        metavar="FILE",
        help="metrics.binproto files (JobMetrics, from stook or ReSim's own writer)",
    )
    parser.add_argument(
        "-o",
        "--output",
        "--out",
        dest="output",
        type=Path,
        metavar="OUT.html",
        help="where to write the page (default: FILE's name with .html beside one FILE, "
        "preview.html here for several)",
    )
    parser.add_argument("--open", action="store_true", help="open the page in a browser")


def _add_metrics_config_arguments(parser: argparse.ArgumentParser) -> None:
    from stook.service.cli._metrics_config import add_arguments

    add_arguments(parser)


_ADD_ARGUMENTS: dict[str, Callable[[argparse.ArgumentParser], None]] = {
    "run": _add_run_arguments,
    "demo": _add_demo_arguments,
    "emulate": _add_emulate_arguments,
    "bench": _add_bench_arguments,
    "validate": _add_validate_arguments,
    "show": _add_show_arguments,
    "preview": _add_preview_arguments,
    "metrics-config": _add_metrics_config_arguments,
}


def main(argv: Sequence[str] | None = None) -> None:
    _signals.install()  # first: a signal from here on ends in one line, imports included
    # The console script skips the interpreter's teardown once the command is done
    # and collects less meanwhile (stook.service.cli._process); a call with arguments
    # leaves its process as it found it.
    end = ProcessEnd() if argv is None else None
    voice: Voice | None = None
    try:
        voice = Voice(argv)
        code = run_cli(argv, voice=voice)
        sys.stdout.flush()  # here, where a closed pipe is caught, not at the exit
    except Interrupted as stop:  # before run_cli took over, or a second signal in its end
        code = (voice or Voice(argv)).interrupted(stop)
    except BrokenPipeError:
        code = _reader_went_away()
    if end is not None:
        end.code = code
    sys.exit(code)


# As a program killed by SIGPIPE ends, the shell's 128 + 13 (docs/cli.md).
EXIT_BROKEN_PIPE = 141


def _reader_went_away() -> int:
    """`stook show FILE | head -1`: the reader has all it wanted. No error and no
    traceback; stdout is pointed at /dev/null so that the interpreter's own flush at exit
    does not fail again (the Python docs' recipe for SIGPIPE)."""
    devnull = os.open(os.devnull, os.O_WRONLY)
    os.dup2(devnull, sys.stdout.fileno())
    return EXIT_BROKEN_PIPE


class Voice:
    """Says how a command ended, exactly once: one JSON event when logging JSON lines, one
    line for a person otherwise (`stook: …` for a failure). Thread-safe, for the signal
    watchdog."""

    def __init__(self, argv: Sequence[str] | None = None) -> None:
        import threading

        # Until the arguments are parsed (a signal during the imports): the format they ask
        # for, read without argparse.
        chosen = os.environ.get("STOOK_LOG_FORMAT", "auto")
        args = list(sys.argv[1:] if argv is None else argv)
        for i, arg in enumerate(args):
            if arg == "--log-format" and i + 1 < len(args):
                chosen = args[i + 1]
            elif arg.startswith("--log-format="):
                chosen = arg.partition("=")[2]
        wanted = _json_logs(_chosen_command(argv), chosen)
        self.json = not _is_tty(sys.stderr) if wanted is None else wanted
        self.logging_ready = False
        self.configure_logging: Callable[[], None] | None = None
        """Set when logging is set up on first use (`show`, `validate`), not up front."""
        self.progress: RecordingProgress | None = None
        self.says_info = True  # False under --log-level warning or error
        self._lock = threading.Lock()
        self._said = False

    def failed(self, error: Exception) -> int:
        # Already imported by the command that failed, unless the failure came first.
        from stook.service.cli._run import ExitCode, exit_code_for, explain
        from stook.service.modes import UserFunctionError

        code = exit_code_for(error)
        shown: BaseException | None = None
        if isinstance(error, UserFunctionError) and error.__cause__ is not None:
            shown = error.__cause__  # the user's own traceback, not stook's wrapper
        elif code is ExitCode.UNEXPECTED:
            shown = error
        message = explain(error)
        self._say("stook failed", f"error: {message}", shown, error=message, exit_code=int(code))
        return int(code)

    def finished(self, written: Written) -> None:
        """`stook run` wrote its output: its summary event, or a line for a person."""
        with self._lock:
            if self._said:
                return
            self._said = True
        if self.json:
            written.log()
        elif self.says_info:
            print(written.line(), file=sys.stderr, flush=True)

    def interrupted(self, stop: Interrupted) -> int:
        counts: dict[str, Any] = {}
        where = ""
        if self.progress is not None and self.progress.listed:
            last = self.progress.last
            counts = {"jobs_done": last.jobs_done, "jobs_listed": last.jobs_listed}
            if last.total is not None:
                counts["jobs_total"] = last.total
            where = f" after {last.of_total()}"
        line = f"interrupted by {stop.signal_name}{where}"
        self._say(
            "stook interrupted",
            line,
            error=line,
            signal=stop.signal_name,
            exit_code=stop.exit_code,
            **counts,
        )
        return stop.exit_code

    def _say(
        self, event: str, line: str, shown: BaseException | None = None, **fields: Any
    ) -> None:
        import traceback

        with self._lock:
            if self._said:
                return
            self._said = True
        if not self.json:
            if shown is not None:
                traceback.print_exception(shown)
            print(f"stook: {line}", file=sys.stderr, flush=True)
        elif self.logging_ready:
            import structlog

            if self.configure_logging is not None:
                self.configure_logging()

            if shown is not None:
                fields["exc_info"] = shown  # rendered into the event's "exception" text
            structlog.get_logger("stook.cli").error(event, **fields)
        else:
            # Before structlog is set up (a signal during the imports): the same event,
            # by hand.
            import json
            from datetime import UTC, datetime

            stamp = datetime.now(UTC).isoformat().replace("+00:00", "Z")
            body = {**fields, "event": event, "level": "error", "timestamp": stamp}
            if shown is not None:
                body["exception"] = "".join(traceback.format_exception(shown))
            print(json.dumps(body), file=sys.stderr, flush=True)


def run_cli(argv: Sequence[str] | None = None, *, voice: Voice | None = None) -> int:
    voice = voice or Voice(argv)
    with _signals.handled(on_give_up=voice.interrupted):
        try:
            code = _run_cli(argv, voice)
        except Interrupted as stop:
            _signals.settle()
            return voice.interrupted(stop)
        except KeyboardInterrupt:  # only where no handler could be installed
            _signals.settle()
            return voice.interrupted(Interrupted(_signals.SIGNALS[0]))
        except BrokenPipeError as error:
            _signals.settle()
            if _chosen_command(argv) == "run":  # `run` writes files, not stdout: a failure
                return voice.failed(error)
            return _reader_went_away()  # stdout's reader closed it: not a failure to report
        except Exception as error:
            _signals.settle()
            return voice.failed(error)
        _signals.settle()
        return code


# Commands that log nothing unless they fail: logging is set up only then, as setting it
# up imports stook.service.api, and with it aiohttp and its TLS contexts (~0.25 s).
_QUIET_COMMANDS = ("show", "validate", "preview", "metrics-config")


def _run_cli(argv: Sequence[str] | None, voice: Voice) -> int:
    command = _chosen_command(argv)
    if not command and not (sys.argv[1:] if argv is None else argv):
        # Bare `stook`: what it can do, not an error.
        _build_parser("").print_help()
        return 0
    args = _build_parser(command).parse_args(argv)
    if hasattr(args, "log_format"):
        from stook.service.modes import configure_logging

        json_logs = _json_logs(args.command, args.log_format)
        configure_logging(json=json_logs, level=args.log_level)
        voice.says_info = args.log_level in ("debug", "info")
    else:
        # Commands without logging flags still log to stderr, never onto their stdout.
        json_logs = _json_logs(args.command, os.environ.get("STOOK_LOG_FORMAT", "auto"))

        def set_up(json_logs: bool | None = json_logs) -> None:
            from stook.service.modes import configure_logging

            configure_logging(json=json_logs, level="warning")

        if args.command in _QUIET_COMMANDS:
            voice.configure_logging = set_up
        else:
            set_up()
    voice.json = not _is_tty(sys.stderr) if json_logs is None else json_logs
    voice.logging_ready = True
    return _dispatch(args, voice)


def _is_tty(stream: Any) -> bool:
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError):
        return False


# What `demo`, `emulate` and `bench` run lives in the stook-testing distribution, which a
# metrics-build image does not install: the emulator and benchmarks are no part of a run.
_TESTING_PACKAGES = ("stook.emulator", "stook.testing", "stook.bench")


def _testing_tool(command: str, module: str) -> Any:
    """`module` from stook-testing, or a usage error saying how to install it."""
    import importlib

    from stook.service.cli._usage import UsageError

    try:
        return importlib.import_module(module)
    except ModuleNotFoundError as exc:
        if exc.name is None or not exc.name.startswith(_TESTING_PACKAGES):
            raise
        raise UsageError(
            f"'stook {command}' needs the stook-testing distribution, which is not installed "
            "(from a checkout: 'make setup', or 'pip install ./service/testing')"
        ) from None


def _dispatch(args: argparse.Namespace, voice: Voice) -> int:
    match args.command:
        case "run":
            from stook.service.cli._run import resolve_options, run
            from stook.service.modes import RecordingProgress, event_loop_factory, for_stream

            options = resolve_options(
                inputs=args.inputs,
                outputs=args.outputs,
                config=args.config,
                allow_missing_jobs=args.allow_missing_jobs,
                project_id=args.project_id,
                preview=args.preview,
                engine=args.engine,
            )
            voice.progress = RecordingProgress(for_stream(label="jobs"))
            loop_factory = event_loop_factory()  # before the run: a bad choice is exit 2
            main = run(options, progress=voice.progress, say=voice.finished)
            _signals.run(main, loop_factory=loop_factory)
            return 0
        case "demo":
            from pathlib import Path

            demo = _testing_tool("demo", "stook.testing._demo")
            return int(demo.run_demo(jobs=args.jobs, output=Path(args.output), seed=args.seed))
        case "emulate":
            emulator_cli = _testing_tool("emulate", "stook.emulator._cli")
            try:
                return int(_signals.run(emulator_cli.emulate(args)))
            except Interrupted as stop:  # Ctrl-C is how an emulator ends: no error
                import structlog

                structlog.get_logger("stook.emulate").info(
                    "emulator stopped", signal=stop.signal_name
                )
                return stop.exit_code
        case "bench":
            from pathlib import Path

            from stook.service.cli._probe_flags import check_probe_flags, run_probe

            check_probe_flags(args)
            bench = _testing_tool("bench", "stook.bench")
            if args.probe:
                return run_probe(bench, args)
            if args.engines:
                bench.run_engine_bench(Path(args.out or "docs/benchmarks"), quick=args.quick)
                return 0
            bench.run_bench(Path(args.out or "docs/benchmarks"), quick=args.quick)
            return 0
        case "preview":
            from stook.service.cli._preview import preview_files

            return preview_files(args.files, args.output, open_browser=args.open)
        case "metrics-config":
            from stook.service.cli import _metrics_config

            return _metrics_config.run(args)
        case "validate":
            from stook.service.cli._inspect import validate_file

            return validate_file(args.file)
        case "show":
            from stook.service.cli._inspect import show_file

            return show_file(args.file, full=args.full)
    raise AssertionError(f"unhandled command {args.command!r}")  # argparse restricts it
