"""Lazy re-exports: a package names its public API, and imports each name on first use.

`stook`'s console script imports ``stook.service`` and ``stook.service.cli`` before its
signal handlers are in place, and a library user importing ``stook.service.api`` for
`redact_url` should not pay for aiohttp: so these packages list their names here instead
of importing them. A package does::

    TYPE_CHECKING = False
    if TYPE_CHECKING:
        from stook.service.api._client import ApiClient   # what mypy and readers see
    else:
        __getattr__, __dir__ = lazy_exports(__name__, {"ApiClient": "stook.service.api._client"})

Only the standard library is imported here (see cli/_main.py for why that matters).
"""

from __future__ import annotations

import importlib
import sys

TYPE_CHECKING = False
if TYPE_CHECKING:
    from collections.abc import Callable, Mapping

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, exports: Mapping[str, str]
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """A module ``__getattr__`` and ``__dir__`` for `package`: each name of `exports` is
    imported from the module it maps to when first asked for, then kept in the package."""

    def get(name: str) -> object:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module), name)
        setattr(sys.modules[package], name, value)  # later lookups skip __getattr__
        return value

    def names() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(exports))

    return get, names
