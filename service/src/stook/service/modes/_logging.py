"""structlog set-up for stook's runs: JSON lines in the platform, readable lines at a terminal,
and the token and presigned-URL signatures scrubbed from every event (:func:`redact_event`,
the last processor before the renderer, after exceptions became text)."""

from __future__ import annotations

import logging
import os
import sys
import uuid
from collections.abc import Mapping
from datetime import date, datetime
from enum import Enum
from typing import TextIO, cast

import structlog
from structlog.typing import EventDict, Processor, WrappedLogger
from yarl import URL

from stook.service.api import redact_text, redact_url

__all__ = ["configure_logging", "redact_event"]

# Deeply nested event values are not expected; the limit only guards against cycles.
_MAX_DEPTH = 8


def redact_event(_logger: WrappedLogger, _method: str, event_dict: EventDict) -> EventDict:
    """structlog processor: mask secrets and URL query values in every value, however nested."""
    return {key: _redact_value(value, 0) for key, value in event_dict.items()}


def _redact_value(value: object, depth: int) -> object:
    if value is None or isinstance(value, bool | int | float):
        return value
    if isinstance(value, str):
        return redact_text(value)
    if isinstance(value, URL):
        return redact_url(value)
    if depth >= _MAX_DEPTH:
        return "<nested too deep>"
    if isinstance(value, Mapping):
        return {str(key): _redact_value(item, depth + 1) for key, item in value.items()}
    if isinstance(value, list | tuple | set | frozenset):
        return [_redact_value(item, depth + 1) for item in value]
    if isinstance(value, BaseException):
        return f"{type(value).__name__}: {redact_text(str(value))}"
    if isinstance(value, uuid.UUID | datetime | date | Enum):
        return str(value)
    # A renderer's repr() of a session or response may hold a full URL: scrub it here.
    return redact_text(repr(value))


def configure_logging(
    *, json: bool | None = None, level: str = "info", stream: TextIO | None = None
) -> None:
    """Route structlog to ``stream`` (stderr by default); ``json=None`` picks JSON lines when
    the stream is not a terminal (the platform collects them), readable lines when it is."""
    out = sys.stderr if stream is None else stream
    # By default each line goes to whatever sys.stderr is when it is written: while a
    # progress bar is drawn, rich puts a proxy there that prints lines above the bar.
    target = cast(TextIO, _CurrentStderr()) if stream is None else stream
    try:
        numeric_level = logging.getLevelNamesMapping()[level.upper()]
    except KeyError:
        raise ValueError(f"unknown log level {level!r}") from None
    renderer: Processor
    stamper: Processor
    if json if json is not None else not _is_tty(out):
        renderer = structlog.processors.JSONRenderer()
        stamper = structlog.processors.TimeStamper(fmt="iso", utc=True)
    else:
        # A person reads these: the local time of day and no padding after the level
        # or the event (structlog pads to 30 columns), so that a line fits 80 columns
        # where its values allow; colours only on a terminal and without NO_COLOR
        # (https://no-color.org).
        colors = _is_tty(out) and not os.environ.get("NO_COLOR")
        renderer = structlog.dev.ConsoleRenderer(colors=colors, pad_level=False, pad_event_to=0)
        stamper = structlog.processors.TimeStamper(fmt="%H:%M:%S", utc=False)
    structlog.configure(
        processors=[
            structlog.contextvars.merge_contextvars,
            structlog.processors.add_log_level,
            stamper,
            structlog.processors.StackInfoRenderer(),
            structlog.processors.format_exc_info,  # text, so that redact_event sees it
            redact_event,
            renderer,
        ],
        wrapper_class=structlog.make_filtering_bound_logger(numeric_level),
        logger_factory=structlog.WriteLoggerFactory(file=target),
        # Not cached: tests and `stook` subcommands reconfigure after loggers exist.
        cache_logger_on_first_use=False,
    )


class _CurrentStderr:
    """A file-like object that writes to the current ``sys.stderr``."""

    def write(self, text: str) -> int:
        return sys.stderr.write(text)

    def flush(self) -> None:
        sys.stderr.flush()


def _is_tty(stream: TextIO) -> bool:
    try:
        return stream.isatty()
    except (AttributeError, ValueError):
        return False
