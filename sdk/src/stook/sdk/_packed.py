"""A DoubleSeries' values as the little-endian float64 bytes of its wire form.

Shared by `stook.sdk._series` (an array viewed on them, with numpy) and the aggregations'
`SeriesByName.packed_of` (the bytes alone, without numpy: this module imports neither
numpy nor polars).
"""

from __future__ import annotations

import functools
import sys
from array import array
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from stook.proto import metrics_pb2 as pb

__all__ = ["packed_doubles", "packed_header"]


def packed_doubles(doubles: pb.DoubleSeries) -> memoryview:
    """The doubles as little-endian float64 bytes, bit for bit.

    A serialized DoubleSeries that holds its values alone is the key of field 1 (packed),
    the length as a varint, then exactly these bytes: re-serializing the field (a memcpy
    in upb) gives every value without a Python float each, and without numpy or polars.
    (`stook.sdk._series.doubles_array` reads the same wire form into an array.)"""
    wire = doubles.SerializeToString()
    # Told by the wire's length alone (no look at the repeated field, which costs a
    # container object): this runs for every fetched job's series.
    header = _HEADERS.get(len(wire)) or _header_of_wire(len(wire))
    if header and wire.startswith(header):
        return memoryview(wire)[len(header) :]
    # Unknown fields beside the values (or no values): element by element.
    values = array("d", doubles.series)
    if sys.byteorder == "big":
        values.byteswap()
    return memoryview(values.tobytes())


@functools.lru_cache(maxsize=256)
def packed_header(payload_len: int) -> bytes:
    """What a serialized DoubleSeries holding only `payload_len` bytes of packed doubles
    starts with: the key of field 1 / wire type 2 and the length as a (minimal) varint,
    as protobuf writes it. Anything else (unknown fields) takes the element path."""
    varint = bytearray()
    while True:
        byte, payload_len = payload_len & 0x7F, payload_len >> 7
        varint.append(byte | 0x80 if payload_len else byte)
        if not payload_len:
            return b"\x0a" + bytes(varint)


# Wire length -> the header a wire of that length starts with if it holds packed doubles
# alone (b"" where none fits); a batch's series have a few hundred lengths.
_HEADERS: dict[int, bytes] = {}
_MAX_HEADERS = 4096


def _header_of_wire(wire_len: int) -> bytes:
    header = b""
    for varint_len in range(1, 11):
        payload_len = wire_len - 1 - varint_len
        if payload_len < 0:
            break
        if payload_len % 8 == 0 and len(packed_header(payload_len)) == 1 + varint_len:
            header = packed_header(payload_len)
            break
    if len(_HEADERS) < _MAX_HEADERS:
        _HEADERS[wire_len] = header
    return header
