"""`[engine]`: one run's fetch and fold split into shards, run elsewhere, merged here.

The driver (this process) lists what is split (the batch's jobs, the report's batches),
cuts it into contiguous shards (`_shards.split`), and hands each shard, with fresh partial
states of the run's aggregations, to a runner: local worker processes or Ray tasks
(`_runners`). Each shard runs the same asyncio fetch core as a local run, with
`[fetch] concurrency` requests in flight *per worker* (what the API sees is workers x
concurrency). The states come back and are merged into the run's aggregations in shard
order, whatever order the shards finish in; the mode's run then checks names, applies the
missing-jobs rule and finishes the aggregations once, as for a local run, so the output's
bytes are the same. What differs per mode (what is split, how the shards' outcomes add up)
is the mode's plan: `BatchPlan`, `ReportPlan`.

The shards' progress reports come back while they run; the driver (`ShardsProgress`) keeps
the last report of each shard still running and adds them to what the finished shards gave; a
finished shard's result supersedes its reports, so that nothing is counted twice.

The `[fetch] deadline` covers the whole run. On the deadline, Ctrl-C or a failed shard the
other shards are stopped (the runner is aborted) and the first failure is raised, with its
own type and message (`_shards.RemoteError`); nothing is written.
"""

from __future__ import annotations

import asyncio
import contextlib
import logging
import pickle
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol, cast

import structlog

from stook.sdk.aggregations import Aggregation, Needs
from stook.service.api import ApiClient, Batch, Job, Report, redact_text
from stook.service.fetch import (
    FetchOutcome,
    JobEmissions,
    ReportFetcher,
    ReportOutcome,
    fetch_emissions,
)
from stook.service.modes._baseline import fetch_baseline, set_directions
from stook.service.modes._config import EngineSettings, StookConfig, import_folders
from stook.service.modes._config_metrics import ConfigMetrics, JobRows
from stook.service.modes._errors import ConfigError, EngineConfigError, ShardError
from stook.service.modes._inputs import BatchInputs, ReportInputs
from stook.service.modes._pipeline import FetchRun, Traffic, fetch_records, show_progress, tick
from stook.service.modes._progress import FetchProgress
from stook.service.modes._shards import (
    BatchShard,
    LogSettings,
    ProcessRunner,
    RayRunner,
    ReportShard,
    ShardDone,
    ShardFailed,
    ShardProgress,
    split,
)

if TYPE_CHECKING:
    from stook.sdk.aggregations.baseline import BaselineComparison

__all__ = ["BatchPlan", "ReportPlan", "fold_sharded"]

log = structlog.get_logger("stook.engine")


class ShardRunner(Protocol):
    """Runs pickled shards somewhere (`_shards.run_shard`) and hands back pickled results."""

    @property
    def workers(self) -> int:
        """How many shards run at once: the default number of shards derives from it."""
        ...

    def listen(self, on_progress: Callable[[ShardProgress], None]) -> None:
        """Call `on_progress`, on the running event loop, with the running shards' reports
        (`_shards.ShardProgress`); a runner that cannot send them never calls it."""
        ...

    def submit(self, task: bytes) -> asyncio.Future[bytes]: ...

    def close(self, *, abort: bool) -> None:
        """Release the workers; `abort`: stop the shards still running, at once."""
        ...


async def fold_sharded(
    run: FetchRun[Any],
    plan: BatchPlan | ReportPlan,
    engine: EngineSettings,
    config_file: Path | None,
) -> tuple[Any, Traffic]:
    """The fetch and fold split into shards, run by `engine`'s workers, merged here."""
    check_states_pickle(run.aggregations)  # before the first request
    # Where the user's modules are imported from, in every worker.
    folders = tuple(str(f) for f in import_folders(config_file))
    runner = _start_runner(engine, folders)
    log.info(
        f"{run.kind} fetch starting",
        **{f"{run.kind}_id": str(run.output_id)},
        engine=engine.kind,
        workers=runner.workers,
        concurrency_per_worker=run.settings.concurrency,
        data=sorted(run.needs.data),
    )
    shards = Shards(run, plan, runner, engine.shards or _default_shards(engine, runner))
    aborted = True
    try:
        # The driver's client, open for the whole run: the listing it splits, and what it
        # fetches beside the shards (a baseline, the emissions logs).
        _, driver = await fetch_records(
            run.access,
            run.settings,
            shards.on,
            _no_records,
            retry=run.retry,
            started=run.started,
            how_far=lambda outcome: run.how_far(outcome, shards.folded),
            then=run.then,
        )
        aborted = False
    finally:
        shards.stop_listening()  # reports still on their way would draw a closed display
        runner.close(abort=aborted)
        run.progress.close()
    return plan.outcome, shards.shards_traffic + driver


def _no_records(_: object) -> None:
    """The driver folds no record: the shards' states are merged (`Shards._merge`)."""


def _start_runner(engine: EngineSettings, folders: tuple[str, ...]) -> ShardRunner:
    logs = _log_settings()
    try:
        if engine.kind == "processes":
            return ProcessRunner(engine, folders, logs)
        if engine.kind == "ray":
            return RayRunner(engine, folders, logs)
    except EngineConfigError as exc:
        raise ConfigError(str(exc)) from None
    raise ValueError(f"unknown engine {engine.kind!r}")


class Shards:
    """One sharded run's driver: list, split, submit, and merge the results in shard order."""

    def __init__(
        self, run: FetchRun[Any], plan: BatchPlan | ReportPlan, runner: ShardRunner, count: int
    ) -> None:
        self._run, self._plan, self._runner, self._count = run, plan, runner, count
        self.folded = 0  # records (jobs, or batches) whose shard is merged
        self.traffic = Traffic()  # the whole run's: the shards' and the driver's
        self.shards_traffic = Traffic()
        self._driver_traffic: Callable[[], Traffic] = Traffic
        self._api: ApiClient | None = None
        self._live = ShardsProgress()  # the running shards' last reports
        self._listening = True
        runner.listen(self._reported)

    def _reported(self, progress: ShardProgress) -> None:
        if self._listening:
            self._live.reported(progress)
            self._show()

    def stop_listening(self) -> None:
        self._listening = False

    def _show(self) -> None:
        snapshot = self._run.progress_of(self._plan.outcome)
        show_progress(self._run.progress, *self._live.add_to(snapshot, self.traffic))

    def on(self, api: ApiClient) -> Shards:
        """The driver as the pipeline's fetcher, on the run's client (`run`)."""
        self._api = api
        return self

    @property
    def outcome(self) -> Any:
        return self._plan.outcome

    async def run(self, _: Callable[[Any], None]) -> Any:
        """List, split, submit, and merge the shards' results in shard order."""
        api, plan = self._api, self._plan
        if api is None:
            raise RuntimeError("Shards.run needs the client: make it with Shards.on(api)")
        ticker = asyncio.create_task(tick(self._show))
        try:

            def listed() -> None:
                self.traffic = self.shards_traffic + Traffic.of(api)
                self._show()

            self._driver_traffic = lambda: Traffic.of(api)
            items = await plan.listing(api, listed)
            self.traffic = self.shards_traffic + Traffic.of(api)
            try:
                await self._run_shards(split(items, self._count))
                await plan.finish(api)
            finally:
                plan.abort()  # a no-op once finished
            self.traffic = self.shards_traffic + Traffic.of(api)
        finally:
            ticker.cancel()
            with contextlib.suppress(asyncio.CancelledError):
                await ticker
        plan.complete()
        self._show()
        return plan.outcome

    async def _run_shards(self, pieces: list[list[Any]]) -> None:
        run, plan = self._run, self._plan
        aggregations = run.aggregations
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
        self.shards_traffic = self.shards_traffic + Traffic(
            requests=result.requests, retries=result.retries, bytes_received=result.bytes_received
        )
        self.traffic = self.shards_traffic + self._driver_traffic()
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
        for aggregation, state in zip(self._run.aggregations, result.states, strict=True):
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


@dataclass(slots=True)
class BatchPlan:
    """The batch's jobs are sharded; with `[batch.baseline]` the baseline's jobs are
    fetched here, on the driver, beside the shards: the comparison needs only their
    listed scalars (one request a job), and its candidate side comes from the shards'
    states like every other aggregation's. With config-defined metrics the jobs'
    emissions logs are fetched here too, beside the shards, over the jobs the driver
    listed (`rows`)."""

    inputs: BatchInputs
    config: StookConfig
    comparison: BaselineComparison | None
    config_metrics: ConfigMetrics | None = None
    outcome: FetchOutcome = field(default_factory=FetchOutcome)
    rows: JobRows | None = None
    _baseline: asyncio.Task[None] | None = None
    _emissions: asyncio.Task[int] | None = None

    async def listing(self, api: ApiClient, on_progress: Callable[[], None]) -> list[Job]:
        inputs, outcome = self.inputs, self.outcome
        comparison, settings = self.comparison, self.config.baseline
        if comparison is not None and settings is not None:
            self._baseline = asyncio.create_task(
                fetch_baseline(
                    api,
                    inputs.access.project_id,
                    inputs.batch_id,
                    comparison,
                    settings,
                )
            )

        def total_is(total: int) -> None:
            outcome.jobs_total = total

        jobs = []
        async for job in api.list_jobs(
            inputs.access.project_id, inputs.batch_id, on_total=total_is
        ):
            jobs.append(job)
            outcome.jobs_listed += 1
            on_progress()
        outcome.jobs_total = outcome.jobs_listed
        if self.config_metrics is not None:
            self._emissions = asyncio.create_task(
                self._fetch_emissions(self.config_metrics, api, jobs)
            )
        return jobs

    async def _fetch_emissions(
        self, config_metrics: ConfigMetrics, api: ApiClient, jobs: list[Job]
    ) -> int:
        project_id, batch_id = self.inputs.access.project_id, self.inputs.batch_id
        rows = self.rows = config_metrics.rows(api, project_id)
        try:
            return await fetch_emissions(
                api,
                project_id,
                list(enumerate(jobs)),
                ids_of=lambda listed: (batch_id, listed[1].job_id),
                on_job=lambda listed, payload: rows.add(
                    JobEmissions(listed[0], batch_id, listed[1], payload)
                ),
            )
        finally:
            await rows.aclose()

    def shard(
        self, run: FetchRun[Any], index: int, items: list[Job], states: list[Aggregation[Any]]
    ) -> BatchShard:
        return BatchShard(
            index,
            run.access,
            run.settings,
            run.retry,
            run.needs,
            states,
            self.inputs.batch_id,
            items,
        )

    def add(self, part: FetchOutcome | ReportOutcome) -> None:
        if not isinstance(part, FetchOutcome):
            raise TypeError(f"a batch shard's outcome is a FetchOutcome, not {type(part).__name__}")
        outcome = self.outcome
        outcome.jobs_done += part.jobs_done
        outcome.jobs_with_metrics += part.jobs_with_metrics
        outcome.missing.extend(part.missing)
        outcome.scalar_names |= part.scalar_names
        outcome.metric_names |= part.metric_names
        outcome.data_names |= part.data_names
        outcome.unnamed_data += part.unnamed_data

    async def finish(self, api: ApiClient) -> None:
        """Every shard is merged: the emissions and the baseline's side too, then the
        comparison's directions."""
        if self._emissions is not None:
            await self._emissions
        comparison, inputs = self.comparison, self.inputs
        if self._baseline is None or comparison is None:
            return
        await self._baseline
        await set_directions(api, inputs.access.project_id, inputs.batch_id, comparison)

    def abort(self) -> None:
        for task in (self._baseline, self._emissions):
            if task is not None:
                task.cancel()

    def complete(self) -> None:
        """Every shard is in (the listing already fixed the job count)."""
        self.outcome.seconds = time.monotonic() - self.outcome.started


@dataclass(slots=True)
class ReportPlan:
    inputs: ReportInputs
    config: StookConfig
    outcome: ReportOutcome = field(default_factory=ReportOutcome)
    _report: Report | None = None

    async def listing(self, api: ApiClient, on_progress: Callable[[], None]) -> list[Batch]:
        inputs = self.inputs
        finder = ReportFetcher(api, inputs.access.project_id, inputs.report_id, Needs())
        report, batches = await finder.find_batches()
        self._report = report
        outcome = self.outcome
        outcome.report = report
        outcome.batches = len(batches)
        outcome.found_batches = batches
        totals = [b.total_jobs for b in batches]
        outcome.jobs_total = None if None in totals else sum(t or 0 for t in totals)
        if batches:
            outcome.first = batches[0].creation_timestamp
            outcome.last = batches[-1].creation_timestamp
        on_progress()
        return batches

    def shard(
        self,
        run: FetchRun[Any],
        index: int,
        items: list[Batch],
        states: list[Aggregation[Any]],
    ) -> ReportShard:
        if self._report is None:
            raise RuntimeError("shards are made after the report's batches are found")
        inputs = self.inputs
        return ReportShard(
            index,
            run.access,
            run.settings,
            run.retry,
            run.needs,
            states,
            inputs.report_id,
            self.config.report.use_summaries,
            self._report,
            items,
        )

    def add(self, part: FetchOutcome | ReportOutcome) -> None:
        if not isinstance(part, ReportOutcome):
            raise TypeError(
                f"a report shard's outcome is a ReportOutcome, not {type(part).__name__}"
            )
        outcome = self.outcome
        outcome.jobs += part.jobs
        outcome.batches_done += part.batches_done
        outcome.jobs_done += part.jobs_done
        outcome.jobs_with_metrics += part.jobs_with_metrics
        outcome.batches_summarised += part.batches_summarised
        outcome.missing.extend(part.missing)
        outcome.job_scalar_names |= part.job_scalar_names

    async def finish(self, api: ApiClient) -> None:
        """Nothing is fetched on the driver after the shards."""

    def abort(self) -> None:
        """Nothing runs on the driver beside the shards."""

    def complete(self) -> None:
        """Every shard is in: the job count is what the batches' listings proved."""
        self.outcome.jobs_total = self.outcome.jobs
        self.outcome.seconds = time.monotonic() - self.outcome.started


class ShardsProgress:
    """The driver's view of its running shards: the last report of each."""

    def __init__(self) -> None:
        self._running: dict[int, ShardProgress] = {}
        self._finished: set[int] = set()

    def reported(self, progress: ShardProgress) -> None:
        if progress.index not in self._finished:  # late: the result is in already
            self._running[progress.index] = progress

    def finished(self, index: int) -> None:
        """Shard `index`'s result is in: it counts from now on, its reports no longer."""
        self._finished.add(index)
        self._running.pop(index, None)

    def add_to(self, snapshot: FetchProgress, traffic: Traffic) -> tuple[FetchProgress, Traffic]:
        """What the finished shards (and the driver) did, with the running shards' reports."""
        running = list(self._running.values())
        if not running:
            return snapshot, traffic
        batches = snapshot.batches_done  # None: batch mode
        if batches is not None:
            batches += sum(p.batches_done for p in running)
        snapshot = replace(
            snapshot,
            jobs_done=snapshot.jobs_done + sum(p.jobs_done for p in running),
            jobs_listed=snapshot.jobs_listed + sum(p.jobs_listed for p in running),
            batches_done=batches,
        )
        for progress in running:
            traffic = traffic + progress.traffic
        return snapshot, traffic
