"""Start-up: which heavy libraries a module pulls in when imported (how long start-up
takes is measured in `stook bench`, not here).

Every package re-exports its names plainly, except `stook.service`, whose names are
imported on first use (the console script's path runs it first); the `stook` command
imports each command's modules when it runs that command; the heavy third-party
libraries are imported by the functions that need them, never at a module's top. These
tests keep them out of the start-up of each command.
"""

from __future__ import annotations

import ast
import subprocess
import sys
import uuid
from pathlib import Path

import pytest

from stook.sdk.example import every_metric_type

# Imported by the functions that need them: frames and series (polars, numpy), statistics
# (scipy), change points (ruptures), previews (plotly), the Ray engine (ray), and
# config-defined metrics (duckdb, sqlglot, liquid).
HEAVY = ("polars", "numpy", "scipy", "ruptures", "plotly", "ray", "duckdb", "sqlglot", "liquid")

PACKAGES = [
    "stook.sdk",
    "stook.sdk.aggregations",
    "stook.sdk.aggregations.baseline",
    "stook.sdk.aggregations.report",
    "stook.sdk.stats",
    "stook.service",
    "stook.service.api",
    "stook.service.fetch",
    "stook.service.modes",
    "stook.service.cli",
    "stook.service.preview",
    "stook.service.metrics_config",
]


def _printed_by(script: str) -> str:
    """What `script` prints, run in a fresh interpreter (which must exit 0)."""
    done = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    return done.stdout


def _heavy_after(code: str) -> str:
    return code + f"\nprint(sorted(m for m in {HEAVY!r} if m in sys.modules))\n"


@pytest.mark.parametrize("package", PACKAGES)
def test_importing_a_package_imports_no_heavy_library(package: str) -> None:
    assert _printed_by(_heavy_after(f"import sys, {package}")) == "[]\n"


# The library below the command: what `stook --help` must not load, nor `show` and
# `validate` beyond the SDK's reader.
LIBRARY = (
    "stook.service.api",
    "stook.service.fetch",
    "stook.service.modes",
    "stook.service.metrics_config",
    "stook.sdk.aggregations",
    "structlog",
    "aiohttp",
)


def test_importing_stook_service_imports_none_of_its_layers() -> None:
    script = (
        "import sys, stook.service\nprint([m for m in sys.modules if m.startswith('stook.')])\n"
    )
    assert _printed_by(script) == "['stook.service']\n"


def test_stook_service_resolves_each_name_from_its_layer() -> None:
    import stook.service
    from stook.service import api, fetch, modes

    homes = {name: layer for layer in (api, fetch, modes) for name in layer.__all__}
    for name in stook.service.__all__:
        assert getattr(stook.service, name) is getattr(homes[name], name), name


def test_stook_service_types_every_name_it_exports() -> None:
    # What type checkers read (the imports under TYPE_CHECKING) is what `__all__` exports.
    import stook.service

    tree = ast.parse(Path(stook.service.__file__).read_text())
    guarded = next(
        n
        for n in tree.body
        if isinstance(n, ast.If) and ast.unparse(n.test) == "typing.TYPE_CHECKING"
    )
    imported = [a.name for n in guarded.body if isinstance(n, ast.ImportFrom) for a in n.names]
    assert sorted(imported) == sorted(stook.service.__all__)


@pytest.mark.parametrize("flag", ["--help", "--version"])
def test_help_and_version_import_no_module_of_the_library(flag: str) -> None:
    library = (*LIBRARY, "stook.sdk", "stook.proto")
    script = (
        "import sys\nfrom stook.service.cli import main\n"
        f"try:\n    main([{flag!r}])\nexcept SystemExit:\n    pass\n"
        f"print(sorted(m for m in {library!r} if m in sys.modules))\n"
    )
    assert _printed_by(script).splitlines()[-1] == "[]"


def test_building_aggregations_lists_no_plugins_before_a_kind_needs_it() -> None:
    # importlib.metadata (~20 ms) is imported only to look for a kind that is not built in.
    script = (
        "import sys, stook.service.modes\n"
        "from stook.sdk.aggregations import build_all\n"
        "build_all({'pass_rate': [{}]}, section='batch')\n"
        "print('importlib.metadata' in sys.modules)\n"
    )
    assert _printed_by(script) == "False\n"


def test_a_local_batch_run_builds_its_aggregations_without_a_heavy_library() -> None:
    # The baseline's statistics (scipy), the report's change points (ruptures) and the
    # Ray engine come with the runs that use them.
    script = (
        "import sys, stook.service.cli._run\n"
        "from stook.service.modes import engine_for, parse\n"
        "from stook.sdk.aggregations import default_batch_aggregations\n"
        "default_batch_aggregations()\n"
        "config = parse({'batch': {'pass_rate': [{}]}, 'report': {'top_n': 3}})\n"
        "config.batch_aggregations()\n"
        "engine_for(config)\n"
    )
    assert _printed_by(_heavy_after(script)) == "[]\n"


def test_show_and_validate_import_no_heavy_library(tmp_path: Path) -> None:
    from stook.sdk import MetricsWriter

    writer = MetricsWriter(uuid.UUID(int=1))
    writer.scalar("speed", 1.0)
    path = str(writer.write(tmp_path / "metrics.binproto"))
    script = (
        "import sys\nfrom stook.service.cli import run_cli\n"
        f"codes = [run_cli(['validate', {path!r}]), run_cli(['show', {path!r}])]\n"
        f"print(codes, sorted(m for m in {HEAVY + LIBRARY!r} if m in sys.modules))\n"
    )
    assert _printed_by(script).splitlines()[-1] == "[0, 0] []"


def test_metrics_config_check_imports_no_http_layer(tmp_path: Path) -> None:
    # It logs nothing unless it fails: logging (which comes with stook.service.api, aiohttp
    # and its TLS contexts) is set up only then.
    from stook.testing.metrics_config_fixture import write_fixture

    config = str(write_fixture(tmp_path / "repo"))
    script = (
        "import sys\nfrom stook.service.cli import run_cli\n"
        f"code = run_cli(['metrics-config', 'check', {config!r}])\n"
        "print(code, sorted(m for m in ('aiohttp', 'stook.service.api') if m in sys.modules))\n"
    )
    assert _printed_by(script).splitlines()[-1] == "0 []"


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


# What a batch run imports only once answers arrive: polars and numpy with the first
# series decoded (tenacity sends every request, the first one too); and what it never
# imports: the report's aggregations (report mode's), the baseline comparison and its
# statistics (a run without [batch.baseline]) and the sharded engine (a local run).
AFTER_THE_FIRST_ANSWERS = (
    "polars",
    "numpy",
    "stook.sdk.aggregations.report",
    "stook.sdk.aggregations.baseline",
    "stook.sdk.stats",
    "stook.service.modes._engine",
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


def test_a_batch_run_sends_its_first_request_before_polars_or_numpy(
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
