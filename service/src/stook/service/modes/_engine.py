"""`[engine]`: one run's fetch and fold split into shards, run elsewhere, merged here.

The driver (this process) lists what is split (the batch's jobs, the report's batches),
cuts it into contiguous shards (`_shards.split`), and hands each shard, with fresh partial
states of the run's aggregations, to a runner: local worker processes
(`_engine_processes`) or Ray tasks (`_engine_ray`). Each shard runs the same asyncio fetch
core as a local run, with `[fetch] concurrency` requests in flight *per worker* (what the
API sees is workers x concurrency). The states come back and are merged into the run's
aggregations in shard order, whatever order the shards finish in; the pipeline then checks
names, applies the missing-jobs rule and finishes the aggregations once, as for a local run,
so the output's bytes are the same.

The `[fetch] deadline` covers the whole run. On the deadline, Ctrl-C or a failed shard the
other shards are stopped (the runner is aborted) and the first failure is raised, with its
own type and message (`_shard_errors`); nothing is written.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import pickle
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Protocol, cast

import structlog

from stook.sdk.aggregations import Aggregation
from stook.service.api import redact_text
from stook.service.fetch import fetch_deadline
from stook.service.modes._config import ConfigError
from stook.service.modes._engine_config import EngineConfigError, EngineSettings
from stook.service.modes._open_api import Traffic, open_api
from stook.service.modes._pipeline import FetchRun, show_progress, tick
from stook.service.modes._shard_errors import ShardError
from stook.service.modes._shard_plans import BatchPlan, ReportPlan, plan_for
from stook.service.modes._shard_progress import LiveShards, ShardProgress
from stook.service.modes._shards import LogSettings, ShardDone, ShardFailed, split

__all__ = ["ShardRunner", "ShardedFetch"]

log = structlog.get_logger("stook.engine")


class ShardRunner(Protocol):
    """Runs pickled shards somewhere (`_shards.run_shard`) and hands back pickled results."""

    @property
    def workers(self) -> int:
        """How many shards run at once: the default number of shards derives from it."""
        ...

    def listen(self, on_progress: Callable[[ShardProgress], None]) -> None:
        """Call `on_progress`, on the running event loop, with the running shards' reports
        (`_shard_progress`); a runner that cannot send them never calls it."""
        ...

    def submit(self, task: bytes) -> asyncio.Future[bytes]: ...

    def close(self, *, abort: bool) -> None:
        """Release the workers; `abort`: stop the shards still running, at once."""
        ...


@dataclass(frozen=True, slots=True)
class ShardedFetch:
    engine: EngineSettings
    folders: tuple[str, ...]  # where the user's modules are imported from, in every worker

    async def __call__(self, run: FetchRun[Any, Any], /) -> tuple[Any, Traffic]:
        mode = run.mode
        plan = plan_for(mode, self.engine.kind)
        check_states_pickle(mode.aggregations)  # before the first request
        runner = self._runner()
        log.info(
            f"{mode.kind} fetch starting",
            **{f"{mode.kind}_id": str(mode.output_id)},
            engine=self.engine.kind,
            workers=runner.workers,
            concurrency_per_worker=run.settings.concurrency,
            data=sorted(run.needs.data),
        )
        shards = Shards(run, plan, runner)
        aborted = True
        try:
            async with fetch_deadline(
                run.settings.deadline,
                started=run.started,
                progress=lambda: mode.how_far(plan.outcome, shards.folded),
            ):
                await shards.run(self.engine.shards or _default_shards(self.engine, runner))
            aborted = False
        finally:
            shards.stop_listening()  # reports still on their way would draw a closed display
            runner.close(abort=aborted)
            run.progress.close()
        return plan.outcome, shards.traffic

    def _runner(self) -> ShardRunner:
        try:
            return self._start_runner()
        except EngineConfigError as exc:
            raise ConfigError(str(exc)) from None

    def _start_runner(self) -> ShardRunner:
        logs = _log_settings()
        if self.engine.kind == "processes":
            from stook.service.modes._engine_processes import ProcessRunner

            return ProcessRunner(self.engine, self.folders, logs)
        if self.engine.kind == "ray":
            from stook.service.modes._engine_ray import RayRunner

            return RayRunner(self.engine, self.folders, logs)
        raise ValueError(f"unknown engine {self.engine.kind!r}")


class Shards:
    """One sharded run's driver: list, split, submit, and merge the results in shard order."""

    def __init__(self, run: FetchRun[Any, Any], plan: BatchPlan | ReportPlan, runner: ShardRunner):
        self._run, self._plan, self._runner = run, plan, runner
        self.folded = 0  # records (jobs, or batches) whose shard is merged
        self.traffic = Traffic()  # the whole run's: the shards' and the driver's
        self._shards_traffic = Traffic()
        self._driver_traffic: Callable[[], Traffic] = Traffic
        self._live = LiveShards()  # the running shards' last reports
        self._listening = True
        runner.listen(self._reported)

    def _reported(self, progress: ShardProgress) -> None:
        if self._listening:
            self._live.reported(progress)
            self._show()

    def stop_listening(self) -> None:
        self._listening = False

    def _show(self) -> None:
        snapshot = self._run.mode.progress(self._plan.outcome)
        show_progress(self._run.progress, *self._live.add_to(snapshot, self.traffic))

    async def run(self, shard_count: int) -> None:
        run, plan = self._run, self._plan
        ticker = asyncio.create_task(tick(self._show))
        try:
            # Open for the whole run: the driver may fetch beside the shards (a baseline).
            async with open_api(run.access, run.settings, run.retry) as api:

                def listed() -> None:
                    self.traffic = self._shards_traffic + Traffic.of(api)
                    self._show()

                self._driver_traffic = lambda: Traffic.of(api)
                items = await plan.listing(api, listed)
                self.traffic = self._shards_traffic + Traffic.of(api)
                try:
                    await self._run_shards(split(items, shard_count))
                    await plan.finish(api)
                finally:
                    plan.abort()  # a no-op once finished
                self.traffic = self._shards_traffic + Traffic.of(api)
        finally:
            ticker.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await ticker
        plan.complete()
        self._show()

    async def _run_shards(self, pieces: list[list[Any]]) -> None:
        run, plan = self._run, self._plan
        aggregations = run.mode.aggregations
        shard_of: dict[asyncio.Future[bytes], int] = {}
        for index, piece in enumerate(pieces):
            states = [a.fresh() for a in aggregations]
            task = pickle.dumps(plan.shard(run, index, piece, states), pickle.HIGHEST_PROTOCOL)
            shard_of[self._runner.submit(task)] = index
        pending = set(shard_of)
        ready: dict[int, ShardDone] = {}
        next_index = 0
        while pending:
            done, pending = await asyncio.wait(pending, return_when=asyncio.FIRST_COMPLETED)
            for future in done:
                result = _result(future, shard_of[future])
                if isinstance(result, ShardFailed):
                    raise result.error.rebuild()
                self._arrived(result)
                ready[result.index] = result
            # In shard order, whatever order they finished in.
            while next_index in ready:
                self._merge(ready.pop(next_index))
                next_index += 1

    def _arrived(self, result: ShardDone) -> None:
        self._plan.add(result.outcome)
        self._live.finished(result.index)  # its result counts now, not its reports
        sizes = [len(state) for state in result.states]
        self._shards_traffic = self._shards_traffic + Traffic(
            requests=result.requests, retries=result.retries, bytes_received=result.bytes_received
        )
        self.traffic = self._shards_traffic + self._driver_traffic()
        log.info(
            "shard finished",
            shard=result.index,
            size=result.size,
            seconds=round(result.seconds, 3),
            state_bytes=sum(sizes),
            largest_state_bytes=max(sizes, default=0),
            requests=result.requests,
        )
        self._show()

    def _merge(self, result: ShardDone) -> None:
        for aggregation, state in zip(self._run.mode.aggregations, result.states, strict=True):
            aggregation.merge(pickle.loads(state))
        self.folded += result.size


def _result(future: asyncio.Future[bytes], index: int) -> ShardDone | ShardFailed:
    """A finished shard's result; a worker that died (killed, out of memory) is a ShardError."""
    try:
        blob = future.result()
    except Exception as exc:  # BrokenProcessPool, Ray's WorkerCrashedError, ...
        raise ShardError(
            f"shard {index}: its worker ended without a result ({type(exc).__name__}: "
            f"{redact_text(str(exc))})"
        ) from None
    result: ShardDone | ShardFailed = pickle.loads(blob)
    return result


def _default_shards(engine: EngineSettings, runner: ShardRunner) -> int:
    # Processes: one shard per worker. Ray: two per CPU, so that a slow shard (a slow
    # node, long series) holds up less of the run.
    return runner.workers if engine.kind == "processes" else 2 * runner.workers


def check_states_pickle(aggregations: Sequence[Aggregation[Any]]) -> None:
    """Partial states travel between processes: one that cannot is a config error, said
    before the first request."""
    for aggregation in aggregations:
        try:
            pickle.dumps(aggregation.fresh(), pickle.HIGHEST_PROTOCOL)
        except Exception as exc:
            raise ConfigError(
                f"aggregation {aggregation.name!r} ({type(aggregation).__name__}) cannot be "
                f"sent to a worker: its state does not pickle ({exc}); use [engine] kind = "
                '"local"'
            ) from None


def _log_settings() -> LogSettings | None:
    """The driver's logging (JSON or not, level), for the workers; None: not set up."""
    if not structlog.is_configured():
        return None
    config = structlog.get_config()
    json = isinstance(config["processors"][-1], structlog.processors.JSONRenderer)
    try:
        level = cast(int, structlog.get_logger().bind().get_effective_level())
    except AttributeError:  # a wrapper class without levels
        return json, "info"
    return json, logging.getLevelName(level).lower()
