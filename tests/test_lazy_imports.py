"""Start-up: which heavy libraries a module pulls in when imported (how long start-up
takes is measured in `stook bench`, not here)."""

from __future__ import annotations

import subprocess
import sys
import uuid
from pathlib import Path

import pytest

from stook.sdk.example import every_metric_type

# What `stook run` imports before its first request, without polars or numpy: those come
# with the first series decoded. `stook show` and `validate` import stook.sdk alone.
MODULES = ["stook.sdk", "stook.sdk.aggregations", "stook.service.modes", "stook.service.fetch"]


def _printed_by(script: str) -> str:
    """What `script` prints, run in a fresh interpreter (which must exit 0)."""
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


@pytest.mark.parametrize("module", MODULES)
def test_importing_does_not_import_polars_or_numpy(module: str) -> None:
    script = (
        f"import sys, {module}\nprint(sorted(m for m in ('polars', 'numpy') if m in sys.modules))\n"
    )
    assert _printed_by(script) == "[]\n"


def test_building_aggregations_lists_no_plugins_before_a_kind_needs_it() -> None:
    # importlib.metadata (~20 ms) is imported only to look for a kind that is not built in.
    script = (
        "import sys, stook.service.modes\n"
        "from stook.sdk.aggregations import build_all\n"
        "build_all({'pass_rate': [{}]}, section='batch')\n"
        "print('importlib.metadata' in sys.modules)\n"
    )
    assert _printed_by(script) == "False\n"


def test_a_local_batch_run_imports_only_what_it_uses() -> None:
    # A batch run builds the default batch aggregations and those of its config: the report
    # aggregations (~30 ms), the baseline settings, comparison and statistics are imported only
    # by the runs that use them; the sharded engines' machinery, the report fetch and the
    # fetch library only by the runs and programs that use those; tomllib only with a file.
    script = (
        "import sys, stook.service.cli._run\n"
        "from stook.service.modes import engine_for, fetch_step_for, parse\n"
        "from stook.sdk.aggregations import default_batch_aggregations\n"
        "default_batch_aggregations()\n"
        "config = parse({'batch': {'pass_rate': [{}]}, 'report': {'top_n': 3}})\n"
        "config.batch_aggregations()\n"
        "fetch_step_for(engine_for(config), None)\n"
        "unused = ('stook.sdk.aggregations.report', 'stook.sdk.aggregations._baseline',\n"
        "          'stook.sdk.stats', 'stook.sdk.aggregations._histogram',\n"
        "          'stook.service.modes._engine', 'stook.service.modes._library',\n"
        "          'stook.service.fetch._report_fetch', 'stook.service.fetch._baseline_find',\n"
        "          'stook.service.modes._baseline_config', 'tomllib')\n"
        "print(sorted(m for m in unused if m in sys.modules))\n"
    )
    assert _printed_by(script) == "[]\n"


def test_show_and_validate_import_neither_the_writer_nor_the_data_constructors() -> None:
    # `stook show` and `validate` read a file: stook.sdk hands out its names on first use,
    # so the writer (with secrets, for its temporary files) is not imported for them, and
    # the rules only by `validate`.
    script = (
        "import sys\nfrom stook.service.cli._inspect import show_file, validate_file\n"
        "unused = ('stook.sdk._writer', 'stook.sdk._atomic', 'stook.sdk._data', 'secrets',\n"
        "          'stook.sdk._validate')\n"
        "print(sorted(m for m in unused if m in sys.modules))\n"
    )
    assert _printed_by(script) == "[]\n"


def test_show_and_validate_import_neither_pathlib_nor_the_typed_metric_views(
    tmp_path: Path,
) -> None:
    # The typed metric views (fourteen dataclasses) are imported by `JobMetricsView.metric`
    # alone, and these commands take the file's name as given: both cost milliseconds of
    # every `stook validate`.
    from stook.sdk import MetricsWriter

    writer = MetricsWriter(uuid.UUID(int=1))
    writer.scalar("speed", 1.0)
    path = str(writer.write(tmp_path / "metrics.binproto"))
    script = (
        "import sys\nfrom stook.service.cli import run_cli\n"
        f"codes = [run_cli(['validate', {path!r}]), run_cli(['show', {path!r}])]\n"
        "unused = ('pathlib', 'stook.sdk._metric_views', 'importlib.metadata')\n"
        "print(codes, sorted(m for m in unused if m in sys.modules))\n"
    )
    assert _printed_by(script).splitlines()[-1] == "[0, 0] []"


def test_previewing_imports_neither_plotly_nor_polars(tmp_path: Path) -> None:
    # `stook preview` embeds plotly.js read from the plotly package's files: the Python
    # package itself (and its numpy) is never imported, nor is polars.
    from stook.sdk import MetricsWriter

    writer = MetricsWriter(uuid.UUID(int=1))
    every_metric_type(tmp_path, tmp_path, writer)
    path = writer.write(tmp_path / "metrics.binproto")
    script = (
        "import sys\nfrom stook.service.preview import render_html\n"
        f"assert render_html({str(path)!r}).startswith('<!DOCTYPE html>')\n"
        "print(sorted(m for m in ('plotly', 'polars', 'numpy') if m in sys.modules))\n"
    )
    assert _printed_by(script) == "[]\n"


def test_the_command_imports_structlog_without_rich_yet_rich_still_draws() -> None:
    # structlog imports rich (~50 ms) for tracebacks stook never draws; the `stook` command
    # hides it from structlog, and the progress bar imports it for real later.
    code = (
        "import sys\n"
        "from stook.service.cli._main import _import_structlog_without_rich\n"
        "_import_structlog_without_rich()\n"
        "import structlog.dev\n"
        "assert structlog.dev.rich is None, 'structlog imported rich'\n"
        "assert 'rich' not in sys.modules\n"
        "import rich.progress\n"
        "print('ok')\n"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=False)
    assert done.stdout.strip() == "ok", done.stderr


# Imports a batch run needs only once answers arrive: the writer and its data constructors
# (for the output), the reader, the typed metric views and protobuf (for downloaded blobs).
AFTER_THE_FIRST_ANSWERS = (
    "google.protobuf",
    "stook.proto",
    "stook.sdk._writer",
    "stook.sdk._data",
    "stook.sdk._reader",
    "stook.sdk._metric_views",
    "stook.service.fetch._job_blobs",
)

# `stook run` until a signal, then the modules of AFTER_THE_FIRST_ANSWERS it has imported.
RUN_UNTIL_SIGNALLED = """
import os, signal, sys
def stop(*_):
    print(sorted(m for m in {modules!r} if m in sys.modules), flush=True)
    os._exit(0)
signal.signal(signal.SIGUSR1, stop)
from stook.service.cli import main
main(["run", "--inputs", {inputs!r}, "--outputs", {outputs!r}])
"""


def test_a_batch_run_sends_its_first_request_before_the_writer_reader_or_protobuf(
    tmp_path: Path,
) -> None:
    # A server that never answers: `stook run` (default config, with the batch summary) is
    # stopped when its first request arrives, and says what it had imported by then.
    import json
    import os
    import signal
    import socket
    import threading

    with socket.create_server(("127.0.0.1", 0)) as server:
        inputs = tmp_path / "inputs"
        inputs.mkdir()
        config = {
            "authToken": "token",
            "apiURL": f"http://127.0.0.1:{server.getsockname()[1]}",
            "batchID": str(uuid.UUID(int=2)),
            "projectID": str(uuid.UUID(int=1)),
        }
        (inputs / "batch_metrics_config.json").write_text(json.dumps(config))
        script = RUN_UNTIL_SIGNALLED.format(
            modules=AFTER_THE_FIRST_ANSWERS, inputs=str(inputs), outputs=str(tmp_path / "out")
        )
        env = {k: v for k, v in os.environ.items() if not k.startswith("STOOK_")}
        child = subprocess.Popen(
            [sys.executable, "-c", script],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
            cwd=tmp_path,
            env=env,
        )

        def stop_at_the_first_request() -> None:
            connection, _ = server.accept()
            with connection:
                connection.recv(1)
                child.send_signal(signal.SIGUSR1)

        waiter = threading.Thread(target=stop_at_the_first_request, daemon=True)
        waiter.start()
        out, _ = child.communicate(timeout=120)
    assert out == "[]\n"
