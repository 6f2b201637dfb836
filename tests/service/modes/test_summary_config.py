"""[output] summary and [report] use_summaries: defaults, parsing, and what they switch."""

from __future__ import annotations

import pytest

from stook.sdk.aggregations import BatchSummaryWriter
from stook.service.modes import ConfigError
from stook.service.modes._batch import batch_aggregations
from stook.service.modes._config import StookConfig, parse


def test_on_by_default() -> None:
    config = parse({})
    assert config.summary is True
    assert config.report.use_summaries is True
    assert StookConfig().summary is True


def test_switched_off() -> None:
    config = parse({"output": {"summary": False}, "report": {"use_summaries": False}})
    assert config.summary is False
    assert config.report.use_summaries is False


@pytest.mark.parametrize(
    ("doc", "message"),
    [
        ({"output": {"summary": "yes"}}, r"\[output\] summary must be true or false"),
        ({"report": {"use_summaries": 1}}, r"\[report\] use_summaries must be true or false"),
    ],
)
def test_a_bad_value_is_a_config_error(doc: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError, match=message):
        parse(doc)


@pytest.mark.parametrize("on", [True, False])
def test_batch_mode_folds_the_summary_only_when_on(on: bool) -> None:
    aggregations = batch_aggregations(parse({"output": {"summary": on}}))
    writers = [a for a in aggregations.all if isinstance(a, BatchSummaryWriter)]
    assert len(writers) == int(on)
    assert (aggregations.summary is not None) == on
