"""A double series' values as the little-endian float64 bytes of their wire form.

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


def packed_doubles(series: pb.Series) -> bytes:
    """The doubles a Series holds as little-endian float64 bytes, bit for bit (none
    when it holds no doubles).

    A serialized Series that holds doubles alone is the key of its field 1 (`doubles`)
    and the length of the DoubleSeries, then the DoubleSeries: the key of its field 1
    (packed), the length, then exactly these bytes. Re-serializing the Series (a memcpy
    in upb) gives every value without a Python float each, and without numpy or polars;
    the Series, not its DoubleSeries, as reading `doubles` off it costs a third as much
    again. (`stook.sdk._series.doubles_array` reads the same wire form into an array.)"""
    wire = series.SerializeToString()
    # Told by the wire's length alone (no look at the repeated field, which costs a
    # container object): this runs for every fetched job's series.
    header = _HEADERS.get(len(wire)) or _header_of_wire(len(wire))
    if header and wire.startswith(header):
        return wire[len(header) :]
    # Unknown fields beside the values (or no values): element by element.
    values = array("d", series.doubles.series)
    if sys.byteorder == "big":
        values.byteswap()
    return values.tobytes()


@functools.lru_cache(maxsize=256)
def packed_header(payload_len: int) -> bytes:
    """What a serialized message holding only a `payload_len`-byte field 1 of wire type
    2 starts with (a DoubleSeries of `payload_len` bytes of packed doubles; a Series of
    a `payload_len`-byte DoubleSeries): the field's key and its length as a (minimal)
    varint, as protobuf writes it. Anything else (unknown fields) takes the element path."""
    varint = bytearray()
    while True:
        byte, payload_len = payload_len & 0x7F, payload_len >> 7
        varint.append(byte | 0x80 if payload_len else byte)
        if not payload_len:
            return b"\x0a" + bytes(varint)


# Wire length -> the header a Series' wire of that length starts with if it holds packed
# doubles alone (b"" where none fits); a batch's series have a few hundred lengths.
_HEADERS: dict[int, bytes] = {}
_MAX_HEADERS = 4096


def _header_of_wire(wire_len: int) -> bytes:
    header = b""
    # Both lengths' varints grow with the values' length: the first that fits the wire's
    # length is the only one (a longer values' length never has a shorter varint).
    for values_len in range(wire_len - 4, -1, -1):
        if values_len % 8:
            continue
        inner = packed_header(values_len)
        outer = packed_header(len(inner) + values_len)
        size = len(outer) + len(inner) + values_len
        if size == wire_len:
            header = outer + inner
            break
        if size < wire_len:
            break
    if len(_HEADERS) < _MAX_HEADERS:
        _HEADERS[wire_len] = header
    return header
