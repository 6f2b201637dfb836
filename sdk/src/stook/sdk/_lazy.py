"""Lazy re-exports: a package names its public API, and imports each name on first use.

Importing ``stook.sdk.aggregations`` for `Needs` should not import every aggregation and
the report ones (a batch run builds a handful): so the package lists where each name
lives instead of importing it. A package does::

    TYPE_CHECKING = False
    if TYPE_CHECKING:
        from stook.sdk.aggregations._base import Needs   # what mypy and readers see
    else:
        __getattr__, __dir__ = lazy_exports(__name__, {"Needs": "._base"})

(the same as stook.service._lazy, which the SDK cannot import).
"""

from __future__ import annotations

import importlib
import sys

# typing.TYPE_CHECKING without importing typing.
TYPE_CHECKING = False
if TYPE_CHECKING:
    from collections.abc import Callable, Mapping

__all__ = ["lazy_exports"]


def lazy_exports(
    package: str, exports: Mapping[str, str]
) -> tuple[Callable[[str], object], Callable[[], list[str]]]:
    """A module ``__getattr__`` and ``__dir__`` for `package`: each name of `exports` is
    imported from the module it maps to (relative to `package` when it starts with a dot)
    when first asked for, then kept in the package; a name mapped to the package's
    submodule of that name (``"data": ".data"``) is that submodule."""

    def get(name: str) -> object:
        module = exports.get(name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        found = importlib.import_module(module, package)
        value = found if found.__name__ == f"{package}.{name}" else getattr(found, name)
        setattr(sys.modules[package], name, value)  # later lookups skip __getattr__
        return value

    def names() -> list[str]:
        return sorted(set(vars(sys.modules[package])) | set(exports))

    return get, names
