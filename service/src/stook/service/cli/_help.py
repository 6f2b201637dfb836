"""The help texts of `stook` that are longer than a line, and the one formatter they share.

Kept beside docs/cli.md's tables (exit codes, mode detection): tests check that every code
the page lists is in `stook run --help`, and that every option says what it does.
"""

from __future__ import annotations

import argparse
import difflib
import re
from typing import NoReturn

RUN_DESCRIPTION = """\
The metrics-build entry point. It detects the mode from what the inputs folder holds
and writes OUTPUTS/metrics.binproto, atomically or not at all:

  report_config.json            report mode: the report's batches, over time
  batch_metrics_config.json     batch mode: every job of the batch, aggregated
  neither (experience/, logs/)  test mode: your [test] metrics function, or a valid
                                empty output

A near-miss config name (batch_metric_config.json) is refused, not run as a test."""

RUN_EPILOG = """\
exit codes:
  0         metrics.binproto written
  1         unexpected error, or your own test-metrics function raised
  2         bad usage, config or inputs (malformed JSON, missing key, non-UUID ID, bad
            TOML, unknown option, a misspelt config file name), or an outputs folder
            that cannot be written: checked before the first request. Or a metric or
            data name that no job has: one close to a name the jobs have ends the run
            with its suggestion once the first 100 jobs' listings show it missing
            from all of them (batch mode, [engine] kind = "local"); any other once
            the fetch is done
  3         the API or object storage failed for [fetch] retry_for, refused the token,
            the report does not exist, more jobs stayed unavailable than
            --allow-missing-jobs allows, an answer over its cap, a listing that never
            ends, or the [fetch] deadline was reached
  4         invalid metrics data: a download could not be decoded, or the output
            would not validate
  5         the output could not be written (disk full, file-size limit, I/O error)
  130, 143  interrupted by SIGINT or SIGTERM

progress: a bar on a terminal (jobs done of the batch's total, rate, ETA, retries),
fitted to its width; off a terminal one "fetch progress" event every 10 s.
STOOK_PROGRESS=auto|bar|log|none picks the display, STOOK_PROGRESS_INTERVAL the seconds
between events. The run ends with one line saying what it wrote (a "metrics written"
event in JSON logs); the status there is the metrics', not the run's.

event loop: uvloop where it is installed (a dependency on Linux and macOS), else
asyncio's; STOOK_EVENT_LOOP=auto|uvloop|asyncio picks it.

Settings come from the flags, then the STOOK_* variables named above, then the
defaults; [fetch], [batch] and [report] tables are read from stook.toml."""

INSPECT_EPILOG = """\
exit codes: 0 {ok}; 2 the file is not there; 4 the file is not JobMetrics{invalid}."""

EMULATE_EPILOG = """\
Serves until Ctrl-C (exit 130). With --inputs it writes batch_metrics_config.json
there, with --report-inputs report_config.json, naming its own URL and token, so that
`stook run --inputs DIR` runs against it. Every EmulatorConfig field is also --set
KEY=VALUE (VALUE as JSON); a later --set wins over a flag. A setting it does not know,
or a value it refuses, exits 2 naming it."""


# Each command's (help line, description, epilog), in the order `stook --help` lists them.
COMMANDS: dict[str, tuple[str, str, str | None]] = {
    "run": (
        "the metrics-build entry point: detect test, batch or report mode and run it",
        RUN_DESCRIPTION,
        RUN_EPILOG,
    ),
    "demo": (
        "run test, batch and report mode against the built-in emulator",
        "Run test mode on the SDK's every-metric-type example, then batch and "
        "report mode against an emulator in its own process; print what each wrote.",
        None,
    ),
    "emulate": (
        "serve the ReSim API emulator (loopback unless --host says otherwise)",
        "Serve an emulated ReSim API and object storage: a seeded batch and "
        "report, with the faults, rate limits and latency you ask for.",
        EMULATE_EPILOG,
    ),
    "bench": (
        "measure batch mode against the emulator and ReSim",
        "Measure batch mode against the emulator (in its own process), a bare "
        "aiohttp loop and ReSim's fetcher; write tables and plots (docs/performance.md). "
        "With --probe: measure your own API and recommend [fetch] concurrency (docs/probe.md).",
        None,
    ),
    "validate": (
        "check a metrics.binproto against every rule",
        "Check a metrics.binproto against every rule the platform enforces, "
        "printing each rule broken with the metric that breaks it.",
        INSPECT_EPILOG.format(ok="valid", invalid=", or it breaks a rule (each one printed)"),
    ),
    "show": (
        "print a summary of a metrics.binproto",
        "Print one line per metric (name, type, status, value) of a "
        "metrics.binproto; it need not be valid to be shown.",
        INSPECT_EPILOG.format(ok="shown", invalid=""),
    ),
    "preview": (
        "draw metrics.binproto files into one self-contained HTML page",
        "Draw one or more metrics.binproto files (test, batch or report outputs) "
        "into one HTML page that works offline, one column per file. Exit 2 for a missing "
        "file, 4 for one that is not JobMetrics, 5 if the page cannot be written.",
        None,
    ),
    "metrics-config": (
        "check or evaluate the platform's config-defined metrics (config.resim.yml), offline",
        "",  # the long text is stook.service.cli._metrics_config.DESCRIPTION
        None,
    ),
}


class HelpFormatter(argparse.HelpFormatter):
    """Descriptions and epilogs laid out by hand kept as written, one-paragraph ones
    wrapped; each option's default after its help, unless the help says it already or
    there is none to show."""

    def _fill_text(self, text: str, width: int, indent: str) -> str:
        if "\n" in text:
            return "".join(indent + line for line in text.splitlines(keepends=True))
        return super()._fill_text(text, width, indent)

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (
            "default" in text
            or default is None
            or isinstance(default, bool)
            or default == []
            or default == argparse.SUPPRESS
            or not action.option_strings
        ):
            return text
        return text + " (default: %(default)s)"


# argparse's own words for a choice it does not know: "invalid choice: 'runn' (choose from
# 'run', 'demo')" (the quotes differ between Python versions).
_INVALID_CHOICE = re.compile(r"invalid choice: '?([^'\s]*)'? \(choose from (.*)\)")


class ArgumentParser(argparse.ArgumentParser):
    """argparse's parser, whose refusal of an unknown command or choice suggests the
    nearest known one (``stook runn``: did you mean 'run'?), as git and pip do."""

    def error(self, message: str) -> NoReturn:
        found = _INVALID_CHOICE.search(message)
        if found:
            given = found.group(1)
            choices = [c.strip(" '\"") for c in found.group(2).split(",")]
            nearest = difflib.get_close_matches(given, choices, n=1, cutoff=0.6)
            if nearest:
                message = f"{message}; did you mean {nearest[0]!r}?"
        super().error(message)
