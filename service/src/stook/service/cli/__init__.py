"""The `stook` command (``stook.service.cli:main``, the console script).

Only `main` and what it needs first are imported here: the rest of the command, and every
layer below it, is imported once the signal handlers are in place (see `_main`).
"""

from stook.service.cli._main import Voice, build_parser, main, run_cli

__all__ = ["Voice", "build_parser", "main", "run_cli"]
