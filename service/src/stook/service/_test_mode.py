"""Test mode: call the user's metrics function on one test's experience and logs."""

from __future__ import annotations

import importlib
import inspect
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import Any

import structlog

from stook.sdk._writer import MetricsWriter
from stook.service._config import ConfigError, StookConfig
from stook.service._inputs import TestInputs

log = structlog.get_logger("stook.test")

TestMetricsFunction = Callable[[Path, Path, MetricsWriter], Any]


class UserFunctionError(Exception):
    """The user's own metrics function raised; its traceback is theirs to read (exit 1)."""


def load_function(reference: str, *, source: str) -> TestMetricsFunction:
    module_name, _, attr = reference.partition(":")
    try:
        function = getattr(importlib.import_module(module_name), attr)
    except (ImportError, AttributeError) as exc:
        raise ConfigError(
            f"{source}: [test] metrics {reference!r} cannot be imported ({exc})"
        ) from None
    if not callable(function):
        raise ConfigError(f"{source}: [test] metrics {reference!r} is not callable")
    return function  # type: ignore[no-any-return]


async def run_test_mode(inputs: TestInputs, config: StookConfig, output: Path) -> Path:
    writer = MetricsWriter(uuid.uuid4())
    if config.test_metrics is None:
        log.warning(
            "no [test] metrics function configured; writing a valid empty metrics file",
            config=config.source,
        )
    else:
        for folder in (inputs.experience_dir, inputs.logs_dir):
            if not folder.is_dir():
                log.warning("test-mode input folder is missing", folder=str(folder))
        function = load_function(config.test_metrics, source=config.source)
        try:
            result = function(inputs.experience_dir, inputs.logs_dir, writer)
            if inspect.isawaitable(result):
                await result
        except Exception as exc:
            raise UserFunctionError(f"{config.test_metrics} raised {exc!r}") from exc
    written = writer.write(output)
    log.info("test metrics written", output=str(written), metrics=len(writer.metrics))
    return written
