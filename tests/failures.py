"""How a `stook` command said that it failed, read back from its stderr in either format.

Console mode ends a failure with one plain line, ``stook: error: …`` (or ``stook:
interrupted by …``); JSON mode with one event, "stook failed" (or "stook interrupted"),
whose ``error`` holds the same text. `failure_lines` turns both into the plain form, so a
failure said in both forms is counted twice, as it should be.
"""

from __future__ import annotations

import json
from typing import Any

PLAIN_PREFIXES = ("stook: error:", "stook: interrupted")
EVENTS = {"stook failed": "stook: error: ", "stook interrupted": "stook: "}


def json_events(err: str) -> list[dict[str, Any]]:
    """Every line of `err` that is a JSON object."""
    events = []
    for line in err.splitlines():
        if not line.startswith("{"):
            continue
        try:
            event = json.loads(line)
        except ValueError:
            continue
        if isinstance(event, dict):
            events.append(event)
    return events


def failure_lines(err: str) -> list[str]:
    """The lines of `err` that report the command's failure, each as plain ``stook: …``."""
    found = [line for line in err.splitlines() if line.startswith(PLAIN_PREFIXES)]
    for event in json_events(err):
        prefix = EVENTS.get(str(event.get("event")))
        if prefix is not None:
            found.append(prefix + str(event["error"]))
    return found


def traceback_text(err: str) -> str:
    """The traceback that came with the failure: the JSON event's ``exception`` text, or,
    in console mode, stderr itself."""
    for event in json_events(err):
        if event.get("event") in EVENTS and "exception" in event:
            return str(event["exception"])
    return err
