"""Running the emulator: in this event loop, until cancelled, or in its own process."""

from __future__ import annotations

import asyncio
import contextlib
import json
import logging
import multiprocessing
import socket
import sys
import uuid
from dataclasses import dataclass
from multiprocessing.connection import Connection
from pathlib import Path
from types import TracebackType
from typing import Any, Self

from aiohttp import web

from stook.emulator._api import API_PREFIX, build_api_app
from stook.emulator._config import EmulatorConfig
from stook.emulator._dataset import Dataset
from stook.emulator._state import EmulatorState
from stook.emulator._stats import EmulatorStats
from stook.emulator._storage import build_storage_app

log = logging.getLogger("stook.emulator")

BATCH_CONFIG = "batch_metrics_config.json"
REPORT_CONFIG = "report_config.json"


@dataclass(frozen=True, slots=True)
class EmulatorInfo:
    """What a client needs to talk to a running emulator (picklable, JSON-able)."""

    api_url: str
    storage_url: str
    token: str
    project_id: uuid.UUID
    batch_id: uuid.UUID
    report_id: uuid.UUID

    def batch_config(self) -> dict[str, str]:
        return {
            "authToken": self.token,
            "apiURL": self.api_url,
            "batchID": str(self.batch_id),
            "projectID": str(self.project_id),
        }

    def report_config(self) -> dict[str, str]:
        return {
            "authToken": self.token,
            "apiURL": self.api_url,
            "projectID": str(self.project_id),
            "reportID": str(self.report_id),
        }

    def write_batch_config(self, inputs_dir: str | Path) -> Path:
        return _write_json(Path(inputs_dir) / BATCH_CONFIG, self.batch_config())

    def write_report_config(self, inputs_dir: str | Path) -> Path:
        return _write_json(Path(inputs_dir) / REPORT_CONFIG, self.report_config())


def _write_json(path: Path, body: dict[str, str]) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(body, indent=2) + "\n")
    return path


def _bound_socket(host: str, port: int) -> socket.socket:
    family = socket.AF_INET6 if ":" in host else socket.AF_INET
    sock = socket.socket(family, socket.SOCK_STREAM)
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
    sock.bind((host, port))
    sock.listen(1024)
    sock.setblocking(False)
    return sock


class Emulator:
    """The emulated ReSim API and object storage, served from this event loop.

    ::

        async with Emulator(EmulatorConfig(jobs_per_batch=200)) as emu:
            emu.write_batch_config(inputs_dir)
            ...  # run a client against emu.api_url
            assert emu.stats.leaked_tokens == 0
    """

    def __init__(
        self,
        config: EmulatorConfig | None = None,
        *,
        host: str = "127.0.0.1",
        api_port: int = 0,
        storage_port: int = 0,
        public_host: str | None = None,
    ) -> None:
        self.config = config or EmulatorConfig()
        self.host = host
        # The name in the URLs it hands out: what clients reach it by. An address that
        # means "every interface" is no address to connect to.
        self.public_host = public_host or ("127.0.0.1" if host in ("0.0.0.0", "::", "") else host)
        self._ports = (api_port, storage_port)
        self._state = EmulatorState(self.config)
        self._runners: list[web.AppRunner] = []
        self._info: EmulatorInfo | None = None

    # ---- lifecycle ----

    async def start(self) -> EmulatorInfo:
        if self._info is not None:
            return self._info
        try:
            api_port = await self._serve(build_api_app(self._state), self._ports[0])
            storage_port = await self._serve(build_storage_app(self._state), self._ports[1])
        except BaseException:
            await self.close()
            raise
        name = f"[{self.public_host}]" if ":" in self.public_host else self.public_host
        storage_url = f"http://{name}:{storage_port}"
        self._state.storage_url = storage_url
        ds = self._state.dataset
        self._info = EmulatorInfo(
            api_url=f"http://{name}:{api_port}{API_PREFIX}",
            storage_url=storage_url,
            token=self.config.token,
            project_id=ds.project_id,
            batch_id=ds.main_batch_id,
            report_id=ds.report.id,
        )
        return self._info

    async def _serve(self, app: web.Application, port: int) -> int:
        runner = web.AppRunner(app, handle_signals=False, access_log=None, shutdown_timeout=0.5)
        await runner.setup()
        self._runners.append(runner)
        sock = _bound_socket(self.host, port)
        await web.SockSite(runner, sock).start()
        bound: int = sock.getsockname()[1]
        return bound

    async def close(self) -> None:
        runners, self._runners = self._runners, []
        for runner in reversed(runners):
            await runner.cleanup()
        self._info = None

    async def __aenter__(self) -> Self:
        await self.start()
        return self

    async def __aexit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        await self.close()

    # ---- what tests and clients use ----

    @property
    def info(self) -> EmulatorInfo:
        if self._info is None:
            raise RuntimeError("the emulator is not running; use `async with Emulator(...)`")
        return self._info

    @property
    def api_url(self) -> str:
        return self.info.api_url

    @property
    def storage_url(self) -> str:
        return self.info.storage_url

    @property
    def token(self) -> str:
        return self.config.token

    @property
    def project_id(self) -> uuid.UUID:
        return self._state.dataset.project_id

    @property
    def batch_id(self) -> uuid.UUID:
        return self._state.dataset.main_batch_id

    @property
    def report_id(self) -> uuid.UUID:
        return self._state.dataset.report.id

    @property
    def dataset(self) -> Dataset:
        return self._state.dataset

    @property
    def stats(self) -> EmulatorStats:
        return self._state.stats

    def advance_clock(self, seconds: float) -> None:
        """Move the emulator's clock on, e.g. to expire presigned URLs without sleeping."""
        self._state.clock_offset += seconds

    def write_batch_config(self, inputs_dir: str | Path) -> Path:
        return self.info.write_batch_config(inputs_dir)

    def write_report_config(self, inputs_dir: str | Path) -> Path:
        return self.info.write_report_config(inputs_dir)


async def serve(
    config: EmulatorConfig | None = None,
    *,
    host: str = "127.0.0.1",
    api_port: int = 0,
    storage_port: int = 0,
) -> None:
    """Serve until cancelled, after printing where."""
    await serve_with_inputs(config, host=host, api_port=api_port, storage_port=storage_port)


async def serve_with_inputs(
    config: EmulatorConfig | None = None,
    *,
    host: str = "127.0.0.1",
    api_port: int = 0,
    storage_port: int = 0,
    inputs_dir: Path | None = None,
    report_inputs_dir: Path | None = None,
    public_host: str | None = None,
) -> None:
    """Serve until cancelled (for `stook emulate`); with `inputs_dir`, first write the
    platform's batch config there, so that `stook run --inputs inputs_dir` uses it, and
    with `report_inputs_dir` the report config (a folder of its own: a report config
    beside a batch config would make that folder report mode)."""
    async with Emulator(
        config,
        host=host,
        api_port=api_port,
        storage_port=storage_port,
        public_host=public_host,
    ) as emu:
        info = emu.info
        written = ""
        for folder, write in (
            (inputs_dir, emu.write_batch_config),
            (report_inputs_dir, emu.write_report_config),
        ):
            if folder is not None:
                written += f"  wrote:     {write(folder)}\n"
        for folder in (inputs_dir, report_inputs_dir):
            if folder is not None:
                written += f"  run:       stook run --inputs {folder}\n"
        listening = f"  listening: {host}\n" if host != emu.public_host else ""
        print(
            f"ReSim emulator ready\n"
            f"  apiURL:    {info.api_url}\n"
            f"  storage:   {info.storage_url}\n"
            f"  authToken: {info.token}\n"
            f"  projectID: {info.project_id}\n"
            f"  batchID:   {info.batch_id}  ({emu.config.jobs_per_batch} jobs)\n"
            f"  reportID:  {info.report_id}  ({emu.config.report_batches} batches)\n"
            f"{listening}"
            f"{written}"
            "Press Ctrl-C to stop.",
            flush=True,
        )
        log.info("emulator serving", extra={"api_url": info.api_url})
        await asyncio.Event().wait()


# ---- in another process ----


def _child_main(config_dict: dict[str, Any], host: str, conn: Connection) -> None:
    async def run() -> None:
        async with Emulator(EmulatorConfig.from_dict(config_dict), host=host) as emu:
            conn.send(emu.info)
            # Serve until the parent asks to stop (or goes away).
            loop = asyncio.get_running_loop()
            await loop.run_in_executor(None, _wait_for_stop, conn)

    try:
        asyncio.run(run())
    except Exception as exc:  # reported to the parent, which raises it
        conn.send(exc)
    finally:
        conn.close()


def _wait_for_stop(conn: Connection) -> None:
    with contextlib.suppress(EOFError):
        conn.recv()


class EmulatorProcess:
    """The emulator in a child process, so that it does not share the client's loop.

    ::

        with EmulatorProcess(EmulatorConfig(jobs_per_batch=5000)) as emu:
            emu.write_batch_config(inputs_dir)
            ... # benchmark a client against emu.api_url
            print(emu.stats().requests)
    """

    def __init__(
        self,
        config: EmulatorConfig | None = None,
        *,
        host: str = "127.0.0.1",
        start_timeout_s: float = 30.0,
    ) -> None:
        self.config = config or EmulatorConfig()
        self.host = host
        self._timeout = start_timeout_s
        self._process: multiprocessing.process.BaseProcess | None = None
        self._conn: Connection | None = None
        self._info: EmulatorInfo | None = None

    def start(self) -> EmulatorInfo:
        ctx = multiprocessing.get_context("spawn")
        parent, child = ctx.Pipe()
        process = ctx.Process(
            target=_child_main,
            args=(self.config.to_dict(), self.host, child),
            name="stook-emulator",
            daemon=True,
        )
        process.start()
        child.close()
        self._process, self._conn = process, parent
        if not parent.poll(self._timeout):
            self.stop()
            raise TimeoutError(f"the emulator process did not start within {self._timeout} s")
        message = parent.recv()
        if isinstance(message, BaseException):
            self.stop()
            raise message
        assert isinstance(message, EmulatorInfo)
        self._info = message
        return message

    def stop(self) -> None:
        conn, process = self._conn, self._process
        self._conn = self._process = None
        self._info = None
        if conn is not None:
            with contextlib.suppress(OSError):
                conn.send("stop")
            conn.close()
        if process is not None:
            process.join(5)
            if process.is_alive():
                process.terminate()
                process.join(5)

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        self.stop()

    @property
    def info(self) -> EmulatorInfo:
        if self._info is None:
            raise RuntimeError("the emulator process is not running")
        return self._info

    @property
    def pid(self) -> int | None:
        """The child process's ID while it runs: benchmarks read its CPU time by it."""
        return self._process.pid if self._process is not None else None

    @property
    def api_url(self) -> str:
        return self.info.api_url

    @property
    def storage_url(self) -> str:
        return self.info.storage_url

    @property
    def token(self) -> str:
        return self.info.token

    @property
    def project_id(self) -> uuid.UUID:
        return self.info.project_id

    @property
    def batch_id(self) -> uuid.UUID:
        return self.info.batch_id

    @property
    def report_id(self) -> uuid.UUID:
        return self.info.report_id

    def write_batch_config(self, inputs_dir: str | Path) -> Path:
        return self.info.write_batch_config(inputs_dir)

    def write_report_config(self, inputs_dir: str | Path) -> Path:
        return self.info.write_report_config(inputs_dir)

    def stats(self) -> EmulatorStats:
        """The child's counters, fetched over its API (blocking; call via to_thread)."""
        import urllib.request

        request = urllib.request.Request(
            self.info.api_url.removesuffix(API_PREFIX) + "/_emulator/stats",
            headers={"Authorization": f"Bearer {self.info.token}"},
        )
        with urllib.request.urlopen(request, timeout=10) as answer:
            body: dict[str, Any] = json.loads(answer.read())
        return EmulatorStats.from_dict(body)


def main(argv: list[str] | None = None) -> None:
    """`python -m stook.emulator [--seed N] [--jobs N] ...`: serve until Ctrl-C."""
    import argparse

    parser = argparse.ArgumentParser(prog="python -m stook.emulator")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--jobs", type=int, default=EmulatorConfig().jobs_per_batch)
    parser.add_argument("--host", default="127.0.0.1")
    parser.add_argument("--api-port", type=int, default=0)
    parser.add_argument("--storage-port", type=int, default=0)
    parser.add_argument("--latency-ms", type=float, default=0.0)
    parser.add_argument(
        "--fault-rate",
        type=float,
        default=0.0,
        help="spread evenly over 5xx, 429, resets and truncations",
    )
    parser.add_argument("--rate-limit", type=float, default=None, help="API requests per second")
    parser.add_argument(
        "--config-json",
        default=None,
        help="an EmulatorConfig as JSON (overrides the options above)",
    )
    args = parser.parse_args(argv)
    if args.config_json:
        config = EmulatorConfig.from_dict(json.loads(args.config_json))
    else:
        each = args.fault_rate / 4
        config = EmulatorConfig(
            seed=args.seed,
            jobs_per_batch=args.jobs,
            latency_ms=args.latency_ms,
            fault_5xx=each,
            fault_429=each,
            fault_reset=each,
            fault_truncate=each,
            rate_limit_rps=args.rate_limit,
        )
    try:
        asyncio.run(
            serve(config, host=args.host, api_port=args.api_port, storage_port=args.storage_port)
        )
    except KeyboardInterrupt:
        sys.exit(0)
