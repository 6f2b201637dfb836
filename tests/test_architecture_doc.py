"""docs/architecture.md lists every module of proto/, sdk/ and service/src, and only those.

Each package has a heading naming it in backticks (``### `stook.sdk.stats` ``); the
modules below it, up to the next heading, are named by their file names in backticks
(`` `_bootstrap.py` ``). A module added without a line in the map, or a line left for a
module that is gone, fails here.
"""

from __future__ import annotations

import re
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
SOURCES = [REPO / "proto" / "src", REPO / "sdk" / "src", REPO / "service" / "src"]
HEADING = re.compile(r"^#+ ")
PACKAGE = re.compile(r"`(stook(?:\.\w+)+)`")
MODULE = re.compile(r"`(\w+)\.py`")


def modules_in_the_tree() -> set[str]:
    found: set[str] = set()
    for root in SOURCES:
        for path in root.rglob("*.py"):
            if path.name != "__init__.py":
                found.add(".".join(path.relative_to(root).with_suffix("").parts))
    return found


def modules_in_the_doc() -> set[str]:
    found: set[str] = set()
    package = None
    for line in (REPO / "docs" / "architecture.md").read_text().splitlines():
        if HEADING.match(line):
            named = PACKAGE.search(line)
            package = named.group(1) if named else None
        elif package is not None:
            found.update(f"{package}.{name}" for name in MODULE.findall(line))
    return found


def test_every_module_is_in_the_architecture_map() -> None:
    assert sorted(modules_in_the_tree() - modules_in_the_doc()) == []


def test_the_architecture_map_lists_no_module_that_is_gone() -> None:
    assert sorted(modules_in_the_doc() - modules_in_the_tree()) == []
