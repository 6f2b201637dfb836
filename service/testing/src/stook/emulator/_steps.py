"""What a report looks like when something changed mid-window, and which experiences
cannot be trusted from one run: the knobs `report_step_change_batch` and
`report_unstable_experiences` of `EmulatorConfig`.

From report batch `report_step_change_batch` on (creation order, from 0), the batch
metric "Mean distance driven" sits `STEP_FACTOR` times higher and every job of experience
`STEP_EXPERIENCE` fails (BLOCKER): a level change in a batch metric's line and in one
experience's failure rate. The jobs of each experience in `report_unstable_experiences`
write a "Localization error" scaled by a factor drawn per batch between 1/`UNSTABLE_SPAN`
and `UNSTABLE_SPAN` (log-uniform), so that it varies wildly from batch to batch.
"""

from __future__ import annotations

import random

from stook.emulator._config import EmulatorConfig

STEP_FACTOR = 1.25
STEP_EXPERIENCE = 0
UNSTABLE_SPAN = 10.0


def stepped(config: EmulatorConfig, report_index: int | None) -> bool:
    """Whether a report batch (its index; None for other batches) is past the step."""
    step = config.report_step_change_batch
    return step is not None and report_index is not None and report_index >= step


def step_status(
    config: EmulatorConfig, report_index: int | None, experience_index: int, conflated: str
) -> str:
    """A job's conflated status once the step applies: the step experience fails."""
    if stepped(config, report_index) and experience_index == STEP_EXPERIENCE:
        return conflated if conflated in ("CANCELLED", "ERROR") else "BLOCKER"
    return conflated


def distance_factor(config: EmulatorConfig, report_index: int | None) -> float:
    return STEP_FACTOR if stepped(config, report_index) else 1.0


def localization_factor(config: EmulatorConfig, experience_index: int, batch_key: str) -> float:
    """How much an unstable experience's jobs in a batch scale their localization error."""
    if experience_index not in config.report_unstable_experiences:
        return 1.0
    u = random.Random(f"{config.seed}:unstable:{batch_key}:{experience_index}").uniform(-1, 1)
    return float(UNSTABLE_SPAN**u)
