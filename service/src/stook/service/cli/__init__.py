"""The `stook` command (``stook.service.cli:main``, the console script).

Names are imported on first use (see stook.service._lazy): `main` installs the signal
handlers before anything heavy is imported, so a signal during the imports still ends in
one line.
"""

from __future__ import annotations

# typing.TYPE_CHECKING without importing typing (see cli/_main.py).
TYPE_CHECKING = False
if TYPE_CHECKING:
    from stook.service.cli._inspect import (
        summary_lines,
    )
    from stook.service.cli._main import (
        Voice,
        build_parser,
        main,
        run_cli,
    )
else:
    from stook.service._lazy import lazy_exports

    __getattr__, __dir__ = lazy_exports(
        __name__,
        {
            "summary_lines": "stook.service.cli._inspect",
            "build_parser": "stook.service.cli._main",
            "main": "stook.service.cli._main",
            "run_cli": "stook.service.cli._main",
            "Voice": "stook.service.cli._main",
        },
    )

__all__ = [
    "Voice",
    "build_parser",
    "main",
    "run_cli",
    "summary_lines",
]
