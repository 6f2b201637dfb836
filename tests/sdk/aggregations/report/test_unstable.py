"""Unstable experiences: ranked by how much their scalar job metrics vary from batch to
batch relative to their level, with the metric behind each."""

from __future__ import annotations

import dataclasses
import uuid

import pytest

from stook.sdk import MetricStatus
from stook.sdk.aggregations import BatchRecord, JobSummary
from stook.sdk.aggregations.report import UnstableExperiences
from stook.sdk.aggregations.report._change_points import noise_scale
from tests.sdk.aggregations.report.support import Output, batch, fold, scrambled

WILD = [1.0, 9.0, 0.5, 7.0, 2.0, 8.0, 0.7, 6.0]
CALM = [10.0, 10.2, 9.9, 10.1, 10.0, 9.8, 10.1, 10.0]
STEP = [5.0, 5.1, 4.9, 5.0, 9.0, 9.1, 8.9, 9.0]  # one level change: not instability


def _records(batches: int = 8) -> list[BatchRecord]:
    out = []
    for i in range(batches):
        record = batch(i, float(i))
        jobs = [
            # two jobs of "wild" per batch: its value there is their median
            JobSummary(uuid.UUID(int=i * 100 + 1), "wild", "PASSED", scalars={"err": WILD[i]}),
            JobSummary(
                uuid.UUID(int=i * 100 + 2), "wild", "PASSED", scalars={"err": WILD[i] + 0.2}
            ),
            JobSummary(
                uuid.UUID(int=i * 100 + 3),
                "calm",
                "PASSED",
                scalars={"err": CALM[i], "speed": 20.0 + (i % 2)},
            ),
            JobSummary(uuid.UUID(int=i * 100 + 4), "step", "PASSED", scalars={"err": STEP[i]}),
            JobSummary(uuid.UUID(int=i * 100 + 5), "zero", "PASSED", scalars={"err": 0.0}),
            JobSummary(uuid.UUID(int=i * 100 + 6), "odd", "PASSED", scalars={"err": float("nan")}),
        ]
        out.append(dataclasses.replace(record, jobs=jobs))
    return out


def test_the_most_variable_experience_ranks_first_with_its_metric() -> None:
    agg = fold(UnstableExperiences(), scrambled(_records()))
    assert isinstance(agg, UnstableExperiences)
    ranking = agg.ranking()
    assert [(i.experience, i.metric) for i in ranking] == [
        ("wild", "err"),
        ("calm", "speed"),  # 20, 21, 20, 21: 5 % of its level beats err's 1 %
        ("step", "err"),
    ]
    wild = [v + 0.1 for v in WILD]  # the median of the two jobs
    level = (sorted(wild)[3] + sorted(wild)[4]) / 2
    assert ranking[0].level == pytest.approx(level)
    assert ranking[0].spread == pytest.approx(noise_scale(wild) / level)
    assert ranking[0].spread > 1.0
    assert ranking[0].batches == 8
    # The step experience moved once: its spread is that of its noise, not of the step.
    assert ranking[2].spread < 0.05
    out = Output(agg)
    bars = out.bars("Unstable experiences")
    assert list(bars) == ["wild", "calm", "step"]
    assert bars["wild"] == pytest.approx(100 * ranking[0].spread)
    text, _ = out.text("Unstable experiences (details)")
    assert text.splitlines()[0] == "| Experience | Metric | Spread | Median | Batches |"
    assert text.splitlines()[2].startswith("| wild | err | ")
    assert "zero" not in text
    assert "odd" not in text


def test_top_n_and_metrics_narrow_it() -> None:
    out = Output(fold(UnstableExperiences(top_n=1, metrics=["err"]), _records()))
    assert out.bars("Unstable experiences") == pytest.approx(
        {"wild": out.bars("Unstable experiences")["wild"]}
    )
    agg = fold(UnstableExperiences(metrics=["err"]), _records())
    assert isinstance(agg, UnstableExperiences)
    assert [i.metric for i in agg.ranking()] == ["err", "err", "err"]
    assert agg.needs().job_metrics
    assert agg.needs().scalars == frozenset({"err"})
    assert UnstableExperiences().needs().every_scalar
    with pytest.raises(ValueError, match="top_n"):
        UnstableExperiences(top_n=0)


def test_too_few_batches_say_so() -> None:
    text, status = Output(fold(UnstableExperiences(), _records(3))).text("Unstable experiences")
    assert status is MetricStatus.NOT_APPLICABLE
    assert text.startswith("No experience has a scalar job metric in 4 or more")
    assert Output(UnstableExperiences()).names == []


def test_order_in_time_matters() -> None:
    records = _records()
    shuffled_times = [
        dataclasses.replace(r, created=records[(3 * i) % 8].created) for i, r in enumerate(records)
    ]
    a = Output(fold(UnstableExperiences(), records)).text("Unstable experiences (details)")
    b = Output(fold(UnstableExperiences(), shuffled_times)).text("Unstable experiences (details)")
    assert a != b
