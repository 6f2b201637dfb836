"""The [report] settings of change points and unstable experiences: read, passed on to the
default report aggregations, and refused before any request when wrong."""

from __future__ import annotations

from typing import Any

import pytest

from stook.sdk.aggregations.report import ChangePoints, ScalarLines, UnstableExperiences
from stook.service.modes import ConfigError
from stook.service.modes._config import ReportSettings, parse
from stook.service.modes._report import report_aggregations

PROJECT = "5e5e5e5e-1111-4222-8333-444444444444"


def test_the_defaults_search_change_points_and_rank_unstable_experiences() -> None:
    config = parse({})
    assert (config.report.change_points, config.report.change_penalty) == (True, 3.0)
    assert config.report.unstable_experiences is True
    built = report_aggregations(config, PROJECT)
    (lines,) = [a for a in built if isinstance(a, ScalarLines)]
    assert lines.change_points is True
    assert sum(isinstance(a, ChangePoints) for a in built) == 1
    assert sum(isinstance(a, UnstableExperiences) for a in built) == 1


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
    built = report_aggregations(config, PROJECT)
    assert not any(isinstance(a, ChangePoints | UnstableExperiences) for a in built)
    (lines,) = [a for a in built if isinstance(a, ScalarLines)]
    assert (lines.change_points, lines.change_penalty) == (False, 5.0)

    on = report_aggregations(parse({"report": {"change_penalty": 4.5, "top_n": 2}}), PROJECT)
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
