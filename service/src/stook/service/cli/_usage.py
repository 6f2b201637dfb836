"""The error of a command line or environment setting that the user must fix (exit 2).

A module of its own so that the commands that raise it (`show`, `validate`, `preview`)
need not import `stook run`'s modules to do so.
"""

from __future__ import annotations

from stook.sdk import StookError


class UsageError(StookError):
    """A command-line or environment setting is unusable (exit code 2)."""
