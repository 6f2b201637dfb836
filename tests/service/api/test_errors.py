"""The error hierarchy drawn in stook.service.api._errors' docstring is the real one."""

from __future__ import annotations

import re

import stook.service.api as api
from stook.sdk import StookError
from stook.service.api import _errors


def _drawn() -> dict[str, str]:
    """Each class in the drawing, with the class drawn as its parent."""
    parents: dict[str, str] = {}
    stack: list[tuple[int, str]] = []
    for line in (_errors.__doc__ or "").splitlines():
        found = re.match(r"^(?P<lead>[\s│├└─]*)(?P<name>[A-Z]\w+)", line)
        if not found or not found.group("name").endswith("Error"):
            continue
        depth = len(found.group("lead"))
        while stack and stack[-1][0] >= depth:
            stack.pop()
        if stack:
            parents[found.group("name")] = stack[-1][1]
        stack.append((depth, found.group("name")))
    return parents


def test_the_drawing_is_the_hierarchy_and_holds_every_error() -> None:
    drawn = _drawn()
    raised = {
        name: cls
        for name, cls in vars(_errors).items()
        if isinstance(cls, type) and issubclass(cls, StookError) and cls is not StookError
    }
    assert set(drawn) == set(raised)
    for name, parent in drawn.items():
        assert raised[name].__bases__[0].__name__ == parent, name
    assert set(raised) <= set(api.__all__)  # every error is public
