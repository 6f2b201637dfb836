"""BaselineComparison: flips per experience, pass rate, metric verdicts, what it writes."""

from __future__ import annotations

import random
import uuid
from datetime import UTC, datetime

import pytest

from stook.sdk import MetricStatus, MetricType
from stook.sdk.aggregations import JobRecord, Scalar
from stook.sdk.aggregations.baseline import BaselineComparison, BaselineInfo
from stook.sdk.stats import ComparisonVerdict as V
from tests.sdk.aggregations.support import BATCH_ID, Output

BASELINE_ID = uuid.UUID("ba5e0000-0000-4000-8000-000000000001")
EXPERIENCES = [uuid.UUID(int=i + 1) for i in range(40)]


def record(side: str, i: int, status: str, scalars: dict[str, float]) -> JobRecord:
    return JobRecord(
        job_id=uuid.UUID(int=(side == "candidate") << 64 | i),
        conflated_status=status,
        experience_name=f"Experience {i:02d}",
        experience_id=EXPERIENCES[i],
        scalars={k: Scalar(v, "m" if k == "Error" else "") for k, v in scalars.items()},
    )


def pair(
    *,
    shift: float = 0.0,
    newly: tuple[int, ...] = (),
    fixed: tuple[int, ...] = (),
    still: tuple[int, ...] = (),
    seed: int = 0,
) -> tuple[list[JobRecord], list[JobRecord]]:
    """Baseline and candidate jobs of 40 experiences: "Error" per experience level plus
    noise (shifted by `shift` in the candidate), "Speed" unchanged."""
    rng = random.Random(seed)
    base, cand = [], []
    for i in range(40):
        level = 1.0 + i / 10
        b_status = "BLOCKER" if i in fixed or i in still else "PASSED"
        c_status = "WARNING" if i in newly or i in still else "PASSED"
        base.append(
            record(
                "baseline",
                i,
                b_status,
                {"Error": level + rng.gauss(0, 0.05), "Speed": 20 + rng.gauss(0, 1)},
            )
        )
        cand.append(
            record(
                "candidate",
                i,
                c_status,
                {"Error": level + shift + rng.gauss(0, 0.05), "Speed": 20 + rng.gauss(0, 1)},
            )
        )
    return base, cand


def compared(base: list[JobRecord], cand: list[JobRecord], **options: object) -> BaselineComparison:
    comparison = BaselineComparison(**options)  # type: ignore[arg-type]
    for job in base:
        comparison.update_baseline(job)
    for job in cand:
        comparison.update(job)
    comparison.set_baseline(
        BaselineInfo(
            BASELINE_ID,
            "nightly-41",
            "planner 1.4",
            datetime(2026, 11, 21, 8, 0, tzinfo=UTC),
            "the previous batch",
        ),
        BATCH_ID,
    )
    comparison.set_directions({"Error": "lower"})
    return comparison


def test_flips_are_named_per_experience() -> None:
    base, cand = pair(newly=(3, 5), fixed=(7,), still=(9,))
    result = compared(base, cand).result()
    assert result is not None
    assert result.newly_failing == ["Experience 03", "Experience 05"]
    assert result.fixed == ["Experience 07"]
    assert result.still_failing == ["Experience 09"]
    output = Output(compared(base, cand))
    assert output.bars("Newly failing and fixed experiences") == {
        "Experience 03": 1.0,
        "Experience 05": 1.0,
        "Experience 07": -1.0,
    }
    text = output.by_name["Compared with baseline"].raw.metric_values.text_metric_values.text
    assert "Newly failing experiences (2): Experience 03, Experience 05" in text
    assert "Fixed experiences (1): Experience 07" in text
    assert "Still failing experiences (1): Experience 09" in text
    assert (
        "Baseline: nightly-41 (batch ba5e0000-0000-4000-8000-000000000001, build planner 1.4"
        in text
    )


def test_a_shift_is_regressed_paired_and_the_rest_unchanged() -> None:
    base, cand = pair(shift=0.2)
    comparison = compared(base, cand)
    result = comparison.result()
    assert result is not None
    verdicts = {m.name: m for m in result.metrics}
    error, speed = verdicts["Error"], verdicts["Speed"]
    assert error.verdict is V.REGRESSED
    assert error.better_from == "failure definition"
    assert error.difference is not None
    assert error.difference.paired
    assert error.difference.low < 0.2 < error.difference.high
    assert speed.verdict in (V.NO_CHANGE, V.INCONCLUSIVE)
    assert speed.better is None  # no direction: a change would be CHANGED
    assert result.status is MetricStatus.FAIL_WARN
    output = Output(comparison)
    chart = output.metric("Error vs baseline", MetricType.BAR_CHART)
    assert chart.status is MetricStatus.FAIL_WARN
    assert output.by_name["Speed vs baseline"].status is MetricStatus.PASSED
    text = output.by_name["Compared with baseline"].raw.metric_values.text_metric_values.text
    assert "- Error: REGRESSED, change +0.19" in text
    assert "paired over 40 experiences; lower is better, from the failure definition" in text
    assert output.view.status is MetricStatus.FAIL_WARN


def test_block_on_regression_blocks_and_better_in_the_config_wins() -> None:
    base, cand = pair(shift=0.2)
    blocked = compared(base, cand, block_on_regression=True)
    result = blocked.result()
    assert result is not None
    assert result.status is MetricStatus.FAIL_BLOCK
    assert Output(blocked).view.status is MetricStatus.FAIL_BLOCK
    improved = compared(base, cand, better={"Error": "higher"}).result()
    assert improved is not None
    assert {m.name: m.verdict for m in improved.metrics}["Error"] is V.IMPROVED
    assert improved.status is MetricStatus.PASSED


def test_a_change_below_min_effect_is_no_change() -> None:
    base, cand = pair(shift=0.05)  # about 2 % of the mean level of 3
    small = compared(base, cand, min_effect=0.05).result()
    strict = compared(base, cand, min_effect=0.0).result()
    assert small is not None
    assert strict is not None
    assert small.metrics[0].verdict is V.NO_CHANGE
    assert strict.metrics[0].verdict is V.REGRESSED


def test_without_a_baseline_it_says_why_and_is_not_applicable() -> None:
    comparison = BaselineComparison()
    comparison.no_baseline("no finished batch of test suite X on branch Y before this one")
    output = Output(comparison)
    assert output.names == ["Compared with baseline"]
    metric = output.by_name["Compared with baseline"]
    assert metric.status is MetricStatus.NOT_APPLICABLE
    assert "no finished batch" in metric.raw.metric_values.text_metric_values.text
    assert comparison.result() is None


def test_unpaired_when_the_batches_ran_different_experiences() -> None:
    base, cand = pair(shift=0.0)
    # Move the candidate onto other experiences: nothing to pair.
    cand = [
        JobRecord(
            job_id=j.job_id,
            conflated_status=j.conflated_status,
            experience_name=f"Other {k}",
            experience_id=uuid.UUID(int=1000 + k),
            scalars=j.scalars,
        )
        for k, j in enumerate(cand)
    ]
    result = compared(base, cand).result()
    assert result is not None
    error = result.metrics[0]
    assert error.difference is not None
    assert not error.difference.paired
    assert error.difference.n_baseline == error.difference.n_candidate == 40
    assert result.newly_failing == result.fixed == []
    text = Output(compared(base, cand)).by_name["Compared with baseline"]
    assert "unpaired, 40 vs 40 jobs" in text.raw.metric_values.text_metric_values.text


def test_pass_rate_difference_has_a_newcombe_interval() -> None:
    base, cand = pair(newly=tuple(range(0, 40, 2)))  # half the experiences now fail
    comparison = compared(base, cand)
    result = comparison.result()
    assert result is not None
    assert result.pass_rate is not None
    assert result.pass_rate.baseline.estimate == 1.0
    assert result.pass_rate.candidate.estimate == 0.5
    assert result.pass_rate.difference.high < 0
    assert result.pass_rate.verdict is V.REGRESSED
    assert result.status is MetricStatus.FAIL_WARN
    output = Output(comparison)
    scalar = output.metric("Pass rate difference vs baseline", MetricType.SCALAR)
    assert scalar.value == pytest.approx(-50.0)
    assert scalar.status is MetricStatus.FAIL_WARN
    assert "Newcombe interval" in scalar.description
    assert "Pass rate vs baseline" in output.names


def test_too_few_values_are_inconclusive_and_metrics_narrow_the_comparison() -> None:
    base, cand = pair()
    one = compared(base[:1], cand[:1]).result()
    assert one is not None
    assert {m.verdict for m in one.metrics} == {V.INCONCLUSIVE}
    narrowed = compared(base, cand, metrics=("Speed",))
    assert narrowed.needs().scalars == frozenset({"Speed"})
    result = narrowed.result()
    assert result is not None
    assert [m.name for m in result.metrics] == ["Speed"]
    assert result.only_candidate == result.only_baseline == []
    extra = compared(base, [*cand, record("candidate", 39, "PASSED", {"New": 1.0})])
    extra.update_baseline(record("baseline", 39, "PASSED", {"Old": 1.0}))
    separate = extra.result()
    assert separate is not None
    assert (separate.only_candidate, separate.only_baseline) == (["New"], ["Old"])
    text = Output(extra).by_name["Compared with baseline"].raw.metric_values.text_metric_values
    assert "Not in the baseline, not compared: New." in text.text
    assert "Only in the baseline, not compared: Old." in text.text
    assert BaselineComparison().needs().every_scalar
    assert set(narrowed.direction_probes()) == {"Speed"}
    configured = compared(base, cand, metrics=("Speed",), better={"Speed": "higher"})
    assert configured.direction_probes() == {}
    assert set(compared(base, cand).direction_probes()) == {"Error", "Speed"}


def test_order_and_merging_do_not_change_a_byte() -> None:
    base, cand = pair(shift=0.1, newly=(1,), fixed=(2,))
    # One job gives another unit: which one is written must not depend on the order.
    odd = cand[39]
    cand[39] = JobRecord(
        job_id=odd.job_id,
        conflated_status=odd.conflated_status,
        experience_name=odd.experience_name,
        experience_id=odd.experience_id,
        scalars={**odd.scalars, "Error": Scalar(odd.scalars["Error"].value, "cm")},
    )
    one = Output(compared(base, cand)).writer.serialize()
    shuffled_base, shuffled_cand = base[::-1], cand[::-1]
    random.Random(4).shuffle(shuffled_cand)
    two = Output(compared(shuffled_base, shuffled_cand)).writer.serialize()
    left, right = compared(base[:20], cand[:25]), compared(base[20:], cand[25:])
    left.merge(right)
    three = Output(left).writer.serialize()
    four = Output(compared(base, cand[::-1])).writer.serialize()
    assert one == two == three == four


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"correction": "bonferroni"}, "correction"),
        ({"confidence": 1.0}, "confidence"),
        ({"min_effect": -0.1}, "min_effect"),
    ],
)
def test_bad_options_are_refused(options: dict[str, object], message: str) -> None:
    with pytest.raises(ValueError, match=message):
        BaselineComparison(**options)  # type: ignore[arg-type]


def test_long_lists_are_cut_and_chart_names_never_collide() -> None:
    from stook.sdk.aggregations._baseline import MAX_BARS, MAX_NAMED

    rng = random.Random(5)
    comparison = BaselineComparison()
    for i in range(160):
        for side, status in (("baseline", "PASSED"), ("candidate", "WARNING")):
            job = JobRecord(
                job_id=uuid.UUID(int=(side == "candidate") << 64 | i),
                conflated_status=status,
                experience_name=f"E{i:03d}",
                experience_id=uuid.UUID(int=i + 1),
                scalars={"Pass rate": Scalar(rng.random())},  # a job metric of that name
            )
            (comparison.update if side == "candidate" else comparison.update_baseline)(job)
    comparison.set_baseline(BaselineInfo(BASELINE_ID), BATCH_ID)
    output = Output(comparison)
    text = output.by_name["Compared with baseline"].raw.metric_values.text_metric_values.text
    assert "Newly failing experiences (160): E000, E001," in text
    assert f"E{MAX_NAMED - 1:03d} and {160 - MAX_NAMED} more" in text
    assert len(output.bars("Newly failing and fixed experiences")) == MAX_BARS
    flips = output.by_name["Newly failing and fixed experiences"]
    assert f"(the first {MAX_BARS} shown)" in flips.description
    assert "Pass rate vs baseline" in output.names  # the batch's pass rate
    assert "Pass rate (job metric) vs baseline" in output.names  # the job metric's chart
