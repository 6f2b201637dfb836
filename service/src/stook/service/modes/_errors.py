"""The modes layer's errors: what a run refuses before it starts, or ends with.

    StookError (stook.sdk)
    ├── ConfigError                stook.toml is missing, malformed or names what no job has (2)
    ├── EngineConfigError          an unusable `[engine]` setting; said as a ConfigError (2)
    ├── InputsError                the inputs folder or a platform config in it is unusable (2)
    ├── OutputsError               the outputs folder cannot be created or written (2)
    ├── ShardError                 a shard failed naming no error type of its own (1)
    └── FetchError (stook.service.fetch)                                             (3)
        └── MissingJobsError       more jobs unavailable than --allow-missing-jobs allows
    Exception
    └── UserFunctionError          the user's own `[test]` metrics function raised (1)

The exit codes in brackets are mapped once, by the CLI, from these classes (and the
lower layers': stook.service.api's ApiError is 3, stook.service.fetch's FetchError 3,
stook.sdk's ReadError 4). A shard's error comes back to the driver as the same class
with the same message (`_shards.RemoteError`).

Also here, since every stook.toml table's parser uses it: `check_number`, the one check
of a number setting, whose refusal says what the file gave instead.
"""

from __future__ import annotations

import json
import math

from stook.sdk import StookError
from stook.service.fetch import FetchError

__all__ = [
    "ConfigError",
    "EngineConfigError",
    "InputsError",
    "MissingJobsError",
    "OutputsError",
    "ShardError",
    "UserFunctionError",
    "check_number",
]


class ConfigError(StookError):
    """stook.toml is missing, malformed or names something that does not exist (exit 2)."""


class EngineConfigError(StookError):
    """An unusable `[engine]` setting (turned into ConfigError, exit code 2)."""


class InputsError(StookError):
    """The inputs folder or a platform config file in it is unusable (exit code 2)."""


class OutputsError(StookError):
    """The outputs folder cannot be created or written by this process (exit code 2)."""


class ShardError(StookError):
    """A shard failed in a way that names no error type of its own (exit code 1)."""


class MissingJobsError(FetchError):
    """More jobs stayed unavailable than --allow-missing-jobs allows (exit code 3)."""


class UserFunctionError(Exception):
    """The user's own metrics function raised; its traceback is theirs to read (exit 1)."""


def check_number(
    value: object,
    setting: str,
    *,
    whole: bool = False,
    between: tuple[float, float] | None = None,
    at_most: float | None = None,
    why: str = "",
    error: type[Exception] = ConfigError,
) -> float:
    """`value` of the number setting `setting` (``[fetch] concurrency``), an int when
    `whole`: positive (and at most `at_most`, `why` saying why), or `between` two bounds
    included; raises `error` saying what it must be and what it got instead (``must be a
    positive integer, got the string "64"``)."""
    kind = "integer" if whole else "number"
    if between is None:
        wanted = f"a positive {kind}"
    else:
        wanted = f"{'an' if whole else 'a'} {kind} from {between[0]:g} to {between[1]:g}"
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or (whole and not isinstance(value, int))
        or not math.isfinite(value)
    ):
        raise error(f"{setting} must be {wanted}, got {_described(value)}")
    low, high = between or (0, math.inf)
    if not low <= value <= high or (between is None and value == 0):
        raise error(f"{setting} must be {wanted}, got {value}")
    if at_most is not None and value > at_most:
        raise error(f"{setting} must be at most {at_most:g}{why}, got {value}")
    return value if whole else float(value)


def _described(value: object) -> str:
    """A TOML value as the file spells it, with its type, which is what is wrong."""
    if isinstance(value, bool):
        return f"the boolean {str(value).lower()}"
    if isinstance(value, str):
        return f"the string {json.dumps(value)}"
    if isinstance(value, float):
        return f"the float {value!r}"
    if isinstance(value, list):
        return "an array"
    if isinstance(value, dict):
        return "a table"
    return f"the {type(value).__name__} {value}"  # a TOML date or time
