"""Test mode's config-defined metrics: the `type: test` metrics of [metrics_config],
over the test's emissions file, written beside what a [test] metrics function writes."""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import structlog

from stook.service.modes._inputs import TestInputs

if TYPE_CHECKING:
    from stook.sdk import MetricsWriter
    from stook.service.metrics_config import MetricsConfig
    from stook.service.modes._metrics_config_settings import MetricsConfigSettings

log = structlog.get_logger("stook.test")

EMISSIONS_NAME = "emissions.resim.jsonl"


@dataclass(frozen=True, slots=True)
class TestConfigMetrics:
    """The loaded config and where the test's emissions are; built before any work, so
    that a bad config is exit 2 before the user's function runs."""

    config: MetricsConfig
    emissions: Path
    metrics_set: str | None
    strict: bool = False

    @classmethod
    def load(
        cls, settings: MetricsConfigSettings, base: Path | None, inputs: TestInputs
    ) -> TestConfigMetrics:
        from stook.service.metrics_config import load_config

        config = load_config(settings.config_paths(base), settings.templates_path(base))
        config.metrics_for("test", settings.metrics_set)  # an unknown set: exit 2 now
        emissions = settings.emissions_path(base) or inputs.logs_dir / EMISSIONS_NAME
        return cls(config, emissions, settings.metrics_set, settings.strict)

    def write_into(self, writer: MetricsWriter, outputs: Path) -> None:
        """Evaluate into `writer`; attached files (images) are copied into `outputs`."""
        from stook.service.metrics_config import EmissionsError, EmissionsSet, JobMeta, evaluate

        emissions = EmissionsSet(self.config)
        found = self.emissions.is_file()
        if not found:
            # As on the platform: a test that emitted nothing has no rows.
            log.warning("no emissions file; config metrics see no rows", path=str(self.emissions))
        emissions.add_job(JobMeta(job_id=str(writer.job_id)), self.emissions if found else None)
        result = evaluate(
            self.config,
            emissions.tables(),
            writer,
            level="test",
            metrics_set=self.metrics_set,
            strict=self.strict,
            attached=lambda name: (self.emissions.parent / name).is_file(),
        )
        for failure in result.failed:
            log.warning(
                "config metric written as an error", metric=failure.metric, error=str(failure)
            )
        for name in result.files:
            source = self.emissions.parent / name
            if not source.is_file():
                raise EmissionsError(f"attached file {name!r} is not beside {self.emissions}")
            shutil.copyfile(source, outputs / name)
        log.info("config metrics evaluated", written=len(result.written), hidden=len(result.hidden))
