"""The [report] settings of change points and unstable experiences: read, passed on to the
default report aggregations, and refused before any request when wrong."""

from __future__ import annotations

import uuid
from typing import Any, cast

import pytest

from stook.sdk.aggregations.report import ChangePoints, ScalarLines, UnstableExperiences
from stook.service.modes._config import ConfigError, ReportSettings, parse
from stook.service.modes._report import report_aggregations_for, searches_change_points

PROJECT = "5e5e5e5e-1111-4222-8333-444444444444"


def test_the_defaults_search_change_points_and_rank_unstable_experiences() -> None:
    config = parse({})
    assert (config.report.change_points, config.report.change_penalty) == (True, 3.0)
    assert config.report.unstable_experiences is True
    built = report_aggregations_for(config, PROJECT)
    (lines,) = [a for a in built if isinstance(a, ScalarLines)]
    assert lines.change_points is True
    assert sum(isinstance(a, ChangePoints) for a in built) == 1
    assert sum(isinstance(a, UnstableExperiences) for a in built) == 1


def test_the_change_point_worker_starts_only_when_the_defaults_search_change_points() -> None:
    assert searches_change_points(parse({})) is True
    assert searches_change_points(parse({"report": {"change_points": False}})) is False
    assert searches_change_points(parse({"report": {"defaults": False}})) is False


def test_the_settings_are_read() -> None:
    config = parse(
        {
            "report": {
                "change_points": False,
                "change_penalty": 5,
                "unstable_experiences": False,
                "top_n": 4,
            }
        }
    )
    assert config.report == ReportSettings(
        top_n=4, change_points=False, change_penalty=5.0, unstable_experiences=False
    )
    assert isinstance(config.report.change_penalty, float)
    built = report_aggregations_for(config, PROJECT)
    assert not any(isinstance(a, ChangePoints | UnstableExperiences) for a in built)
    (lines,) = [a for a in built if isinstance(a, ScalarLines)]
    assert (lines.change_points, lines.change_penalty) == (False, 5.0)

    on = report_aggregations_for(parse({"report": {"change_penalty": 4.5, "top_n": 2}}), PROJECT)
    (changes,) = [a for a in on if isinstance(a, ChangePoints)]
    (unstable,) = [a for a in on if isinstance(a, UnstableExperiences)]
    assert (changes.penalty, changes.top_n, unstable.top_n) == (4.5, 2, 2)


@pytest.mark.parametrize(
    ("report", "message"),
    [
        ({"change_points": "yes"}, "[report] change_points must be true or false"),
        ({"unstable_experiences": 1}, "[report] unstable_experiences must be true or false"),
        ({"change_penalty": 0}, "[report] change_penalty must be a positive number"),
        ({"change_penalty": True}, "[report] change_penalty must be a positive number"),
        ({"change_pnealty": 3}, "unknown key 'change_pnealty' in [report]"),
        (
            {"change_points": [{"penalty": -1}]},
            "[[report.change_points]] #1: penalty must be positive",
        ),
        (
            {"unstable_experiences": [{"top_n": "3"}]},
            "[[report.unstable_experiences]] #1: option 'top_n' cannot be '3'",
        ),
    ],
)
def test_bad_settings_are_config_errors(report: dict[str, Any], message: str) -> None:
    with pytest.raises(ConfigError) as caught:
        parse({"report": report}, source="s.toml")
    assert message in str(caught.value)
    assert str(caught.value).startswith("s.toml: ")


def test_report_tables_build_the_new_kinds() -> None:
    config = parse(
        {
            "report": {
                "defaults": False,
                "change_points": [{"name": "Moves", "penalty": 4.0, "experiences": False}],
                "unstable_experiences": [{"top_n": 3, "metrics": ["err"]}],
            }
        }
    )
    changes, unstable = config.report_aggregations()
    assert isinstance(changes, ChangePoints)
    assert (changes.name, changes.penalty, changes.experiences) == ("Moves", 4.0, False)
    assert isinstance(unstable, UnstableExperiences)
    assert (unstable.top_n, unstable.metrics) == (3, ["err"])


@pytest.mark.parametrize(("settings", "started"), [({}, [40]), ({"change_points": False}, [])])
def test_found_batches_start_the_change_point_worker_when_the_search_will_need_it(
    monkeypatch: pytest.MonkeyPatch, settings: dict[str, object], started: list[int]
) -> None:
    # `stook run` and `run_report` fetch through ReportMode.fetcher, whose fetch calls
    # `batches_found`; the sharded engines call it once they have found the batches.
    from stook.sdk.aggregations import Needs
    from stook.sdk.aggregations import report as report_package
    from stook.service.modes import _report
    from stook.service.modes._inputs import ApiAccess, ReportInputs

    calls: list[object] = []

    class Worker:
        def __init__(self, on_failure: object) -> None:
            calls.append("made")

        def start(self, *, batches: int) -> bool:
            calls.append(batches)
            return True

        def close(self) -> None:
            calls.append("closed")

    monkeypatch.setattr(report_package, "ChangePointWorker", Worker)
    access = ApiAccess("http://127.0.0.1:9", "token", uuid.UUID(PROJECT))
    mode = _report.ReportMode(ReportInputs(access, uuid.uuid4()), parse({"report": settings}))
    fetcher = mode.fetcher(cast(Any, None), Needs(), lambda outcome: None)
    assert fetcher._on_batches_found == mode.batches_found
    mode.batches_found(40)
    mode.batches_found(41)  # once a run
    mode.close()
    assert calls == (["made", *started, "closed"] if started else [])
