"""The `stook` command (``stook.service.cli:main``, the console script)."""

from stook.service.cli._main import (
    Voice,
    build_parser,
    main,
    run_cli,
)

__all__ = [
    "Voice",
    "build_parser",
    "main",
    "run_cli",
]
