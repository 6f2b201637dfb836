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
"""

from __future__ import annotations

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
