"""A metric's query reaches its tables and nothing else: a file, a URL, an extension or
a setting is refused by `check` naming the function or construct, and `eval` writes
and prints no byte of what it would have read, and sends no request."""

from __future__ import annotations

import http.server
import socket
import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from stook.service.cli._main import run_cli
from stook.service.metrics_config import QueryError
from stook.service.metrics_config._query_engine import QueryEngine
from stook.testing.metrics_config_fixture import write_fixture
from tests.service.metrics_config.emitted import emit_job, make_job

SECRET = "token-7f3a9c-not-for-metrics"


@pytest.fixture(autouse=True)
def _console_errors(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("STOOK_LOG_FORMAT", "console")


@pytest.fixture
def secret_file(tmp_path: Path) -> Path:
    path = tmp_path / "secret.csv"
    path.write_text(f"token\n{SECRET}\n", encoding="utf-8")
    return path


@pytest.fixture
def listener() -> Iterator[tuple[str, list[str]]]:
    """A local HTTP server recording every request it gets."""
    seen: list[str] = []

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            seen.append(self.path)
            self.send_response(200)
            self.end_headers()
            self.wfile.write(b"token\nfrom-the-network\n")

        def log_message(self, *args: object) -> None:
            pass

    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    server = http.server.HTTPServer(("127.0.0.1", port), Handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{port}/secret.csv", seen
    finally:
        server.shutdown()
        server.server_close()


def _hostile(secret: Path, url: str) -> list[tuple[str, str]]:
    """(query, what the refusal must name)."""
    return [
        (f"SELECT content AS value FROM read_text('{secret}')", "read_text"),
        (f"SELECT token AS value FROM read_csv('{secret}')", "read_csv"),
        (f"SELECT token AS value FROM read_csv_auto('{secret}')", "read_csv_auto"),
        (f"SELECT * FROM read_json_auto('{secret}')", "read_json_auto"),
        (f"SELECT content AS value FROM read_blob('{secret}')", "read_blob"),
        (f"SELECT file AS value FROM glob('{secret.parent}/*')", "glob"),
        (f"SELECT token AS value FROM '{secret}'", str(secret)),
        (f'SELECT token AS value FROM "{secret}"', str(secret)),
        (f"SELECT token AS value FROM read_csv('{url}')", "read_csv"),
        (f"SELECT token AS value FROM '{url}'", url),
        ("SELECT current_setting('threads') AS value", "current_setting"),
        ("SELECT getenv('HOME') AS value", "getenv"),
        ("SELECT name AS value FROM duckdb_settings()", "duckdb_settings"),
        ("SELECT name AS value FROM pg_settings", "pg_settings"),
        ("SELECT table_name AS value FROM information_schema.tables", "information_schema"),
        ("SET enable_external_access = true", "SET"),
        ("PRAGMA version", "PRAGMA"),
        ("INSTALL httpfs", "INSTALL"),
        ("LOAD httpfs", "LOAD"),
        (f"ATTACH '{secret.parent}/x.db'", "does not parse"),  # not Trino SQL at all
        (f"COPY speed TO '{secret.parent}/out.csv'", "COPY"),
    ]


def _config_with(tmp_path: Path, query: str) -> Path:
    config = write_fixture(tmp_path / "repo")
    text = config.read_text(encoding="utf-8")
    start = text.index('SELECT MAX(speed) AS "Max speed" FROM speed')
    quoted = query.replace("'", "''")
    config.write_text(
        text[:start]
        + f"'{quoted}'"
        + text[start + len('SELECT MAX(speed) AS "Max speed" FROM speed') :],
        encoding="utf-8",
    )
    return config


def test_hostile_queries_are_refused_by_check_and_eval(
    tmp_path: Path,
    secret_file: Path,
    listener: tuple[str, list[str]],
    capsys: pytest.CaptureFixture[str],
) -> None:
    url, requests = listener
    for k, (query, named) in enumerate(_hostile(secret_file, url)):
        where = tmp_path / f"case-{k}"
        config = _config_with(where, query)
        assert run_cli(["metrics-config", "check", str(config)]) == 2, query
        err = capsys.readouterr().err
        assert "Traceback" not in err
        (line,) = [ln for ln in err.splitlines() if "Max speed" in ln]
        assert named.lower() in line.lower(), (query, line)
        assert SECRET not in err

        emissions = emit_job(where / "job", config, make_job(0))
        out = where / "out"
        # Refused, the metric is written as an error (exit 0); with --strict, exit 4 and
        # nothing written. Either way no byte of what it would read is shown.
        for strict in ([], ["--strict"]):
            code = run_cli(
                ["metrics-config", "eval", str(config), "--emissions", str(emissions),
                 "--level", "test", "--output", str(out), *strict]
            )  # fmt: skip
            # (A query sqlglot cannot even parse, `glob(...)`, makes the config itself
            # bad: exit 2 before anything runs.)
            assert code in ((4 if strict else 0), 2), query
            captured = capsys.readouterr()
            assert SECRET not in captured.err + captured.out
            assert "refused" in captured.err or "does not parse" in captured.err, captured.err
            written = out / "metrics.binproto"
            if strict or code == 2:
                assert not written.exists()
            else:
                assert SECRET.encode() not in written.read_bytes()
                written.unlink()
    assert requests == []
    assert not (secret_file.parent / "out.csv").exists()
    assert not (secret_file.parent / "x.db").exists()


def test_the_engine_itself_reads_no_file_even_past_the_allow_list(secret_file: Path) -> None:
    """The engine's own settings, not only the allow-list: DuckDB is asked directly."""
    import duckdb
    import polars as pl

    with QueryEngine({"t": pl.DataFrame({"x": [1]})}) as engine:
        con = engine._con  # the connection as configured, past _sql's check
        for sql in (
            f"SELECT * FROM read_text('{secret_file}')",
            f"SELECT * FROM '{secret_file}'",
            "SET enable_external_access = true",
            "SET lock_configuration = false",
            "INSTALL httpfs",
        ):
            with pytest.raises(duckdb.Error) as caught:
                con.execute(sql).fetchall()
            assert SECRET not in str(caught.value)
        with pytest.raises(QueryError, match="read_text"):
            engine.run("m", f"SELECT content FROM read_text('{secret_file}')")
