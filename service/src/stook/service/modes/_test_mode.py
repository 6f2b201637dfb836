"""Test mode: call the user's metrics function on one test's experience and logs."""

from __future__ import annotations

import importlib
import inspect
import time
import uuid
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import structlog

from stook.sdk import MetricsWriter
from stook.service.modes._config import StookConfig, add_import_folders, describe_search
from stook.service.modes._errors import ConfigError, UserFunctionError
from stook.service.modes._inputs import TestInputs
from stook.service.modes._pipeline import RunResult, Traffic

if TYPE_CHECKING:
    # The writer only for a test-mode run: `stook run` imports this module for
    # UserFunctionError whatever the mode.
    from stook.sdk import MetricsWriter

log = structlog.get_logger("stook.test")

TestMetricsFunction = Callable[[Path, Path, "MetricsWriter"], Any]


def load_function(
    reference: str, *, source: str, config_file: Path | None = None
) -> TestMetricsFunction:
    """Import ``module:function``, from `config_file`'s folder and the working directory first."""
    module_name, _, attr = reference.partition(":")
    add_import_folders(config_file)
    try:
        module = importlib.import_module(module_name)
    except ImportError as exc:
        raise ConfigError(
            f"{source}: [test] metrics {reference!r} cannot be imported ({exc}); "
            f"{describe_search(config_file)}"
        ) from None
    try:
        function = getattr(module, attr)
    except AttributeError as exc:
        raise ConfigError(
            f"{source}: [test] metrics {reference!r} cannot be imported ({exc}; "
            f"module {module_name!r} is {module.__file__})"
        ) from None
    if not callable(function):
        raise ConfigError(f"{source}: [test] metrics {reference!r} is not callable")
    return function  # type: ignore[no-any-return]


async def run_test_mode(inputs: TestInputs, config: StookConfig, output: Path) -> RunResult[None]:
    """The user's test-metrics function (and the config's test metrics) on one test, its
    metrics written to `output`; what was written, as batch and report mode say it."""
    started = time.monotonic()
    writer = MetricsWriter(uuid.uuid4())
    config_metrics = None
    if config.metrics_config is not None:
        from stook.service.modes._config_metrics import TestConfigMetrics

        base = config.file.parent if config.file else None
        config_metrics = TestConfigMetrics.load(config.metrics_config, base, inputs)
    if config.test_metrics is None and config_metrics is None:
        log.warning(
            "no [test] metrics function configured; writing a valid empty metrics file",
            config=config.source,
        )
    elif config.test_metrics is not None:
        for folder in (inputs.experience_dir, inputs.logs_dir):
            if not folder.is_dir():
                log.warning("test-mode input folder is missing", folder=str(folder))
        function = load_function(config.test_metrics, source=config.source, config_file=config.file)
        try:
            result = function(inputs.experience_dir, inputs.logs_dir, writer)
            if inspect.isawaitable(result):
                await result
        except Exception as exc:
            raise UserFunctionError(f"{config.test_metrics} raised {exc!r}") from exc
    if config_metrics is not None:
        config_metrics.write_into(writer, output.parent)
    return RunResult(
        kind="test",
        output=writer.write(output),
        outcome=None,
        metrics_written=[metric.name for metric in writer.metrics],
        status=writer.status,
        traffic=Traffic(),
        counts={},
        seconds=time.monotonic() - started,
    )
