"""``Change points``: where, within the report, a batch metric or an experience's failure
rate moved to a new level, and which batch (and build) brought the move."""

from __future__ import annotations

import uuid
from collections import Counter
from dataclasses import dataclass, field
from typing import Self, TypeVar

from stook.sdk import _data
from stook.sdk._enums import MetricStatus
from stook.sdk._writer import MetricsWriter
from stook.sdk.aggregations._base import Aggregation, BatchRecord, Needs, pick_unit
from stook.sdk.aggregations.report._change_points import (
    DEFAULT_PENALTY,
    MIN_POINTS,
    PENALTY_CONSTANT,
    Shift,
    level_shifts,
    rate_shifts,
)
from stook.sdk.aggregations.report._experiences import FAILED, PASSED
from stook.sdk.aggregations.report._timeline import (
    BatchPoint,
    axis,
    axis_name,
    counts,
    first_seen,
    status_in,
)

_T = TypeVar("_T")


@dataclass(frozen=True, slots=True)
class _Batch:
    point: BatchPoint
    build_id: uuid.UUID | None


@dataclass(frozen=True, slots=True)
class Move:
    """One change point as the ``Change points`` text says it.

    `kind` is ``"metric"`` (a batch metric's value) or ``"failure rate"`` (an
    experience's share of failed jobs, 0..1); `subject` the metric or experience name;
    `batch` the first batch at the new level, `build_id` the build it ran.
    """

    kind: str
    subject: str
    batch: BatchPoint
    build_id: uuid.UUID | None
    before: float
    after: float
    unit: str = ""

    @property
    def relative_change(self) -> float | None:
        return None if self.before == 0 else (self.after - self.before) / abs(self.before)


@dataclass(frozen=True, slots=True)
class ChangePointSummary:
    """What the ``Change points`` text metric says, with the moves it lists."""

    status: MetricStatus
    text: str
    moves: tuple[Move, ...] = ()


@dataclass
class ChangePoints(Aggregation[BatchRecord]):
    """A TEXT ``Change points``: every change of level found (penalised change points,
    PELT) on each SCALAR batch metric's line and on each experience's failure rate
    (failed jobs, BLOCKER or ERROR, out of its jobs that passed or failed, per batch),
    naming the batch and build where the level moved, the level before and after.

    A LINE_PLOT ``Failure rate over time`` draws the `top_n` experiences whose failure
    rate moved most, each batch where it moved marked FAIL_WARN. The text is FAIL_WARN
    when a failure rate rose (a batch metric's move is reported, not judged: stook does
    not know which way is better), PASSED otherwise, NOT_APPLICABLE with fewer than 5
    batches. `penalty` multiplies ln n in the penalty (see docs/change-points.md).
    """

    name: str = "Change points"
    penalty: float = DEFAULT_PENALTY
    top_n: int = 10
    experiences: bool = True

    batches: dict[uuid.UUID, _Batch] = field(default_factory=dict, init=False)
    values: dict[str, dict[uuid.UUID, float]] = field(default_factory=dict, init=False)
    units: dict[str, Counter[str]] = field(default_factory=dict, init=False)
    outcomes: dict[str, dict[uuid.UUID, tuple[int, int]]] = field(default_factory=dict, init=False)

    def __post_init__(self) -> None:
        if self.penalty <= 0:
            raise ValueError("penalty must be positive")
        if self.top_n < 1:
            raise ValueError("top_n must be at least 1")

    def needs(self) -> Needs:
        return Needs(every_scalar=True)

    def update(self, record: BatchRecord) -> None:
        point = BatchPoint(record.created, record.batch_id, record.name)
        self.batches[record.batch_id] = _Batch(point, record.build_id)
        for metric, scalar in record.scalars.items():
            self.values.setdefault(metric, {})[record.batch_id] = scalar.value
            self.units.setdefault(metric, Counter())[scalar.unit] += 1
        if not self.experiences:
            return
        columns = record.job_columns()
        names, codes = columns.experience_names()
        failed = status_in(columns, FAILED)
        # Cancelled, unknown: neither passed nor failed, not counted.
        counted = codes[failed | status_in(columns, PASSED)]
        failures = counts(codes[failed], len(names))
        jobs = counts(counted, len(names))
        for code in first_seen(counted):
            self.outcomes.setdefault(names[code], {})[record.batch_id] = (
                failures[code],
                jobs[code],
            )

    def merge(self, other: Self) -> None:
        self.batches.update(other.batches)
        for metric, by_batch in other.values.items():
            self.values.setdefault(metric, {}).update(by_batch)
        for metric, units in other.units.items():
            self.units.setdefault(metric, Counter()).update(units)
        for experience, outcome in other.outcomes.items():
            self.outcomes.setdefault(experience, {}).update(outcome)

    # ---- the search, on the complete state ----

    def _ordered(self, by_batch: dict[uuid.UUID, _T]) -> list[tuple[_Batch, _T]]:
        return sorted(
            ((self.batches[b], v) for b, v in by_batch.items()), key=lambda bv: bv[0].point
        )

    def metric_moves(self) -> list[Move]:
        moves = []
        for metric in sorted(self.values):
            series = self._ordered(self.values[metric])
            unit = pick_unit(self.units[metric])
            for shift in level_shifts([v for _, v in series], factor=self.penalty):
                moves.append(_move("metric", metric, series[shift.index][0], shift, unit))
        return moves

    def judged_experiences(self) -> list[str]:
        return sorted(e for e, o in self.outcomes.items() if len(o) >= MIN_POINTS)

    def rate_moves(self) -> dict[str, list[Move]]:
        judged = self.judged_experiences()
        out = {}
        for experience in judged:
            series = self._ordered(self.outcomes[experience])
            shifts = rate_shifts(
                [f for _, (f, _) in series],
                [c for _, (_, c) in series],
                factor=self.penalty,
                series=len(judged),
            )
            if shifts:
                out[experience] = [
                    _move("failure rate", experience, series[s.index][0], s, "") for s in shifts
                ]
        return out

    def summary(self) -> ChangePointSummary | None:
        """What the ``Change points`` text says; None before any batch."""
        if not self.batches:
            return None
        points = sorted(b.point for b in self.batches.values())
        span = f"{len(points)} batches ({points[0].name} to {points[-1].name})"
        if len(points) < MIN_POINTS:
            return ChangePointSummary(
                MetricStatus.NOT_APPLICABLE,
                f"No change-point search: {span}; at least {MIN_POINTS} are needed.",
            )
        metric_moves = self.metric_moves()
        rate_moves = self.rate_moves()
        moves = metric_moves + [m for e in sorted(rate_moves) for m in rate_moves[e]]
        lines_judged = sum(1 for by in self.values.values() if len(by) >= MIN_POINTS)
        judged = len(self.judged_experiences())
        what = f"{len(set(m.subject for m in metric_moves))} of {lines_judged} batch metrics"
        if self.experiences:
            what += f" and {len(rate_moves)} of {judged} experiences' failure rates"
        method = (
            f"PELT change points, penalty {self.penalty:g} ln n + {PENALTY_CONSTANT:g} for n "
            "batches (batch metrics on a robust noise scale"
        )
        if self.experiences:
            method += f"; failure rates binomial, plus 2 ln {max(judged, 1)} across experiences"
        method += "); see docs/change-points.md."
        if not moves:
            return ChangePointSummary(
                MetricStatus.PASSED,
                f"No change point: no level moved in {what} over {span}. " + method,
            )
        rose = any(m.kind == "failure rate" and m.after > m.before for m in moves)
        text = (
            f"{len(moves)} change point{'s' if len(moves) > 1 else ''} in {what} over {span}:\n"
            + "\n".join(f"- {_say(m)}" for m in moves)
            + "\n\n"
            + method
        )
        return ChangePointSummary(
            MetricStatus.FAIL_WARN if rose else MetricStatus.PASSED, text, tuple(moves)
        )

    def finish(self, writer: MetricsWriter) -> None:
        summary = self.summary()
        if summary is None:
            return
        writer.text(self.name, summary.text, status=summary.status)
        rate_moves: dict[str, list[Move]] = {}
        for move in summary.moves:
            if move.kind == "failure rate":
                rate_moves.setdefault(move.subject, []).append(move)
        if rate_moves:
            self._draw_rates(writer, rate_moves)

    def _draw_rates(self, writer: MetricsWriter, rate_moves: dict[str, list[Move]]) -> None:
        biggest = sorted(
            rate_moves, key=lambda e: (-max(abs(m.after - m.before) for m in rate_moves[e]), e)
        )[: self.top_n]
        origin = min(b.point for b in self.batches.values()).created
        label = "Failure rate over time"
        xs, ys, statuses = [], [], []
        for experience in biggest:
            series = self._ordered(self.outcomes[experience])
            starts = {m.batch for m in rate_moves[experience]}
            times, x = axis(f"{label}: {experience}", origin, [b.point for b, _ in series])
            xs.append(x)
            ys.append(
                _data.doubles(
                    f"{label}: {experience}",
                    [100.0 * f / c for _, (f, c) in series],
                    unit="%",
                    index=times,
                )
            )
            statuses.append(
                _data.statuses(
                    f"{label}: {experience} (statuses)",
                    [
                        MetricStatus.FAIL_WARN if b.point in starts else MetricStatus.PASSED
                        for b, _ in series
                    ],
                    index=times,
                )
            )
        writer.line_plot(
            label,
            xs,
            ys,
            statuses=statuses,
            x_axis_name=axis_name(origin),
            y_axis_name="Failed jobs [%]",
            legend=biggest,
            status=MetricStatus.FAIL_WARN
            if any(m.after > m.before for e in biggest for m in rate_moves[e])
            else MetricStatus.PASSED,
            description=(
                f"Per batch, the share of each experience's jobs that failed (BLOCKER or "
                f"ERROR), for the {len(biggest)} experience(s) whose failure rate moved most; "
                "the batch where it moved is marked."
            ),
        )


def _move(kind: str, subject: str, at: _Batch, shift: Shift, unit: str) -> Move:
    return Move(kind, subject, at.point, at.build_id, shift.before, shift.after, unit)


def _say(move: Move) -> str:
    at = move.batch
    build = f"build {str(move.build_id)[:8]}, " if move.build_id is not None else ""
    where = f"at {at.name} ({build}{at.created:%Y-%m-%d %H:%M} UTC)"
    if move.kind == "failure rate":
        points = 100.0 * (move.after - move.before)
        return (
            f"{move.subject!r} failure rate moved {where}: {move.before:.0%} → "
            f"{move.after:.0%} ({points:+.0f} points)."
        )
    u = f" {move.unit}" if move.unit else ""
    relative = move.relative_change
    pct = f" ({relative:+.1%})" if relative is not None else ""
    return f"{move.subject!r} moved {where}: {move.before:.6g}{u} → {move.after:.6g}{u}{pct}."
