"""Synthetic camera frames (PNG, standard library only) for the example's IMAGE metrics.

The SDK example names front.png and rear.png beside its metrics.binproto; the demo and
the preview's tests write these so that the preview has real images to embed.
"""

from __future__ import annotations

import struct
import zlib
from pathlib import Path


def _chunk(kind: bytes, payload: bytes) -> bytes:
    body = kind + payload
    return struct.pack(">I", len(payload)) + body + struct.pack(">I", zlib.crc32(body))


def camera_frame_png(width: int = 320, height: int = 180, *, hue: int = 0) -> bytes:
    """A road seen from a car: sky, horizon, grey road with dashed lane lines."""
    horizon = height * 2 // 5
    rows = []
    for y in range(height):
        row = bytearray([0])  # filter type: none
        for x in range(width):
            if y < horizon:
                shade = 150 + 90 * y // horizon
                pixel = (110 + hue // 2, shade, 235)
            else:
                depth = (y - horizon) / (height - horizon)
                half_road = 0.05 + 0.45 * depth
                offset = abs(x / width - 0.5)
                if offset < half_road:
                    lane = abs(offset - half_road * 0.5) < 0.01 + 0.01 * depth
                    dash = int(depth * 12) % 2 == 0
                    pixel = (230, 230, 210) if lane and dash else (90, 92, 96)
                else:
                    pixel = (70, 130 - hue // 4, 60)
            row += bytes(pixel)
        rows.append(bytes(row))
    header = struct.pack(">IIBBBBB", width, height, 8, 2, 0, 0, 0)  # 8-bit RGB
    return (
        b"\x89PNG\r\n\x1a\n"
        + _chunk(b"IHDR", header)
        + _chunk(b"IDAT", zlib.compress(b"".join(rows), 9))
        + _chunk(b"IEND", b"")
    )


def write_example_frames(folder: Path) -> list[Path]:
    """front.png and rear.png, as stook.sdk.example's image metrics name them."""
    written = []
    for name, hue in (("front.png", 0), ("rear.png", 60)):
        path = folder / name
        path.write_bytes(camera_frame_png(hue=hue))
        written.append(path)
    return written
