"""The change-point worker process: `python -m stook.sdk._pelt_worker`.

Started by `ChangePointWorker` (stook.sdk.aggregations.report) as soon as a report will
need a change-point search, it imports ruptures (and scipy under it, about a second of
CPU) on another core while the report is fetched, then runs `_pelt.search` for each
request on its stdin and answers on its stdout, until its stdin ends: when the parent
closes it, or dies. It runs in a session of its own, so that a terminal's Ctrl-C
reaches only the parent, and it ignores SIGINT: its end is the parent's to decide, and a
SIGTERM ends it without a word (it writes nothing to stderr; the parent gives it none).
Its messages, both ways, are pickles after their length
(`write_message`, `read_message`): pickle between two processes of the same program,
which arrays cross exactly (float64 bits, dtype, shape).

Requests are ``(id, kind, signal, penalty, min_size)``; replies ``(id, cuts)``, with
cuts None where the search raised (the parent then searches itself, and raises the same).
"""

from __future__ import annotations

import os
import pickle
import signal
import struct
import sys
from typing import IO, Any

_HEADER = struct.Struct("<Q")


def write_message(stream: IO[bytes], message: Any) -> None:
    """`message`, pickled after its length, flushed."""
    blob = pickle.dumps(message, pickle.HIGHEST_PROTOCOL)
    stream.write(_HEADER.pack(len(blob)) + blob)
    stream.flush()


def read_message(stream: IO[bytes]) -> Any:
    """The next message; None at the end of the stream (EOFError if it ends inside one)."""
    header = stream.read(_HEADER.size)
    if not header:
        return None
    if len(header) < _HEADER.size:
        raise EOFError("the stream ended inside a message's length")
    (size,) = _HEADER.unpack(header)
    blob = stream.read(size)
    if len(blob) < size:
        raise EOFError("the stream ended inside a message")
    return pickle.loads(blob)


def serve(requests: IO[bytes], replies: IO[bytes]) -> None:
    """Answer each request with its search's breakpoints until `requests` ends."""
    from stook.sdk._pelt import prepare, search

    prepare()  # ruptures imported now, while the parent fetches, not at its first request
    while (request := read_message(requests)) is not None:
        ident, kind, series, pen, min_size = request
        try:
            cuts: list[int] | None = search(kind, series, pen, min_size)
        except Exception:
            cuts = None
        write_message(replies, (ident, cuts))


def main() -> None:
    # The parent starts this worker in a session of its own, out of reach of a terminal's
    # Ctrl-C; one sent here all the same is the parent's to act on: it closes this
    # worker's stdin when its run ends (or dies, which closes it too).
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    requests = sys.stdin.buffer
    # The replies go to the stdout this process was given; anything else printed here
    # (a library's warning) goes to stderr, so that it cannot break a message.
    replies = os.fdopen(os.dup(sys.stdout.fileno()), "wb")
    os.dup2(sys.stderr.fileno(), sys.stdout.fileno())
    serve(requests, replies)
    replies.flush()
    # Nothing to tear down: the parent waits for this exit, so it should be quick.
    os._exit(0)


if __name__ == "__main__":
    main()
