"""Shared helpers: the `madenet` command line (to check Python against it), a comparison of a
study's table with its trials.csv, and a PNG reader."""

import os
import pathlib
import shutil
import struct
import zlib

import numpy as np
import pytest

REPO = pathlib.Path(__file__).resolve().parents[4]


@pytest.fixture(scope="session")
def cli() -> str:
    """The `madenet` binary: $MADENET_CLI, else the workspace's release or debug build, else PATH."""
    candidates = [os.environ.get("MADENET_CLI"), REPO / "target/release/madenet", REPO / "target/debug/madenet", shutil.which("madenet")]
    for c in candidates:
        if c and pathlib.Path(c).is_file():
            return str(c)
    pytest.fail("the madenet command line is needed: `cargo build --release -p madenet` or set MADENET_CLI")


def assert_same_rows(table: dict, rows: list, tolerance: float, extra=()):
    """`table` (a study's, from madenet) holds `rows` (its trials.csv's), value for value: the
    wall-clock columns aside, names exactly, `to_*` with -1 for an empty cell, `completed` as a
    bool, numbers within `tolerance`; and it has the columns `extra`."""
    import madenet  # here: the helpers that do not need the built package load without it

    assert len(table["method"]) == len(rows)
    for i, row in enumerate(rows):
        for column, value in row.items():
            if column in madenet.TIMING_COLUMNS:
                continue
            got = table[column][i]
            if column in ("method", "map", "start"):
                assert got == value, column
            elif column.startswith("to_"):
                assert got == (int(value) if value else -1), column
            elif column == "completed":
                assert bool(got) == (value == "true"), column
            else:
                assert float(got) == pytest.approx(float(value), abs=tolerance), (column, i)
    for column in extra:
        assert column in table


def read_png_rgb(path) -> np.ndarray:
    """A non-interlaced 8-bit RGB/RGBA PNG as an [H, W, 3] uint8 array (stdlib only: zlib and the
    five PNG row filters), so the tests need no imaging library."""
    data = pathlib.Path(path).read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, header = 8, b"", None
    while pos < len(data):
        (length,) = struct.unpack(">I", data[pos:pos + 4])
        kind, body = data[pos + 4:pos + 8], data[pos + 8:pos + 8 + length]
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", body)
        elif kind == b"IDAT":
            idat += body
        pos += 12 + length
    width, height, depth, color, _, _, interlace = header
    assert depth == 8 and color in (2, 6) and interlace == 0, header
    bpp = 3 if color == 2 else 4
    raw = zlib.decompress(idat)
    stride = width * bpp
    out = np.zeros((height, stride), dtype=np.uint8)
    prev = np.zeros(stride, dtype=np.int32)
    for y in range(height):
        f = raw[y * (stride + 1)]
        line = np.frombuffer(raw, dtype=np.uint8, count=stride, offset=y * (stride + 1) + 1).astype(np.int32)
        cur = np.zeros(stride, dtype=np.int32)
        for x in range(stride):
            a = cur[x - bpp] if x >= bpp else 0
            b = prev[x]
            c = prev[x - bpp] if x >= bpp else 0
            if f == 0:
                p = 0
            elif f == 1:
                p = a
            elif f == 2:
                p = b
            elif f == 3:
                p = (a + b) // 2
            else:
                pa, pb, pc = abs(b - c), abs(a - c), abs(a + b - 2 * c)
                p = a if pa <= pb and pa <= pc else (b if pb <= pc else c)
            cur[x] = (line[x] + p) & 0xFF
        out[y] = cur
        prev = cur
    return out.reshape(height, width, bpp)[:, :, :3]
