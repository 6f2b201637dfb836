"""A shard's failure carried back to the driver as plain values, and raised there again.

Exceptions do not reliably survive pickling: ours take keyword-only arguments
(`ApiStatusError(status=..., url=...)`), which `pickle` cannot call them with, and a user's
aggregation may raise anything. So a worker sends the error's class (by import path) and its
one-line, already redacted message; the driver raises an instance of the same class with
that message, so that the run's exit code (`cli/_run.py exit_code_for`) and its one line are
what a local run gives. Errors that are not stook's own also carry the worker's traceback,
as a note, for the unexpected-error report (exit 1).
"""

from __future__ import annotations

import importlib
import traceback
from dataclasses import dataclass

from stook.sdk import StookError
from stook.service.api import redact_text

__all__ = ["RemoteError", "ShardError"]


class ShardError(StookError):
    """A shard failed in a way that names no error type of its own (exit code 1)."""


@dataclass(frozen=True, slots=True)
class RemoteError:
    module: str
    qualname: str
    message: str
    trace: str | None = None  # the worker's traceback, for errors that are not stook's

    @classmethod
    def of(cls, error: BaseException) -> RemoteError:
        kind = type(error)
        trace = None
        if not isinstance(error, StookError):
            trace = redact_text("".join(traceback.format_exception(error)))
        return cls(kind.__module__, kind.__qualname__, redact_text(str(error)), trace)

    def rebuild(self) -> Exception:
        """An exception of the worker's class with its message (ShardError if it cannot be)."""
        kind = _find(self.module, self.qualname)
        error: Exception
        if kind is not None and issubclass(kind, Exception):
            # Not kind(message): constructors with keyword-only arguments would refuse it.
            error = kind.__new__(kind, self.message)
            Exception.__init__(error, self.message)
        else:
            error = ShardError(f"{self.qualname}: {self.message}")
        if self.trace is not None:
            error.add_note(f"in a worker:\n{self.trace}")
        return error


def _find(module: str, qualname: str) -> type | None:
    try:
        found: object = importlib.import_module(module)
        for part in qualname.split("."):
            found = getattr(found, part)
    except (ImportError, AttributeError):
        return None
    return found if isinstance(found, type) else None
