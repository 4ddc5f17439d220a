"""Checks a partial film (`lumo render --film`, a NumPy `.npz` archive) against the chunk it
was asked to hold, before the driver accepts it."""

from __future__ import annotations

import io
import json
import zipfile
from dataclasses import dataclass

import numpy as np

FORMAT = "lumo-partial-film"

# (member, dtype, trailing shape after (h, w)) of the arrays every film holds.
ARRAYS = (
    ("sum_hi", np.dtype("<i8"), (3,)),
    ("sum_lo", np.dtype("<u8"), (3,)),
    ("sum_sq_hi", np.dtype("<i8"), (3,)),
    ("sum_sq_lo", np.dtype("<u8"), (3,)),
    ("finite", np.dtype("<u4"), ()),
    ("dropped", np.dtype("<u4"), ()),
)


class FilmRejected(Exception):
    """The film is not the one asked for; the message says why."""


@dataclass(frozen=True)
class Expected:
    """What every film of a job must be: the bundle's scene, resolution and lumo build."""

    scene_hash: str
    width: int
    height: int
    lumo_version: str
    build_id: str


def read_header(data: bytes) -> dict:
    """The JSON header of a partial film."""
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            raw = npz["header"]
    except (OSError, ValueError, KeyError, zipfile.BadZipFile, EOFError) as e:
        raise FilmRejected(f"not a readable partial film ({e})") from None
    try:
        header = json.loads(raw.tobytes())
    except ValueError as e:
        raise FilmRejected(f"its header is not JSON ({e})") from None
    if not isinstance(header, dict):
        raise FilmRejected("its header is not a JSON object")
    return header


def check_film(data: bytes, expected: Expected, start: int, end: int) -> dict:
    """Checks that `data` is a complete partial film of samples `start..end` of the expected
    scene, resolution and build; returns its header or raises `FilmRejected`."""
    header = read_header(data)

    def field(name: str, want, what: str) -> None:
        got = header.get(name)
        if got != want:
            raise FilmRejected(f"wrong {what} {got!r} (expected {want!r})")

    field("format", FORMAT, "format")
    field("scene_hash", expected.scene_hash, "scene (hash)")
    field("lumo_version", expected.lumo_version, "lumo version")
    field("build_id", expected.build_id, "lumo build")
    if (header.get("width"), header.get("height")) != (expected.width, expected.height):
        raise FilmRejected(
            f"wrong resolution {header.get('width')}×{header.get('height')} "
            f"(expected {expected.width}×{expected.height})"
        )
    field("crop", [0, 0, expected.width, expected.height], "crop window")
    field("samples", [[start, end]], "sample ranges")
    h, w, spp = expected.height, expected.width, end - start
    try:
        with np.load(io.BytesIO(data), allow_pickle=False) as npz:
            arrays = {}
            for name, dtype, tail in ARRAYS:
                if name not in npz.files:
                    raise FilmRejected(f"it has no `{name}` array")
                a = npz[name]
                if a.dtype != dtype or a.shape != (h, w, *tail):
                    raise FilmRejected(
                        f"wrong `{name}` array {a.dtype}{list(a.shape)} "
                        f"(expected {dtype}{[h, w, *tail]})"
                    )
                arrays[name] = a
    except (OSError, ValueError, zipfile.BadZipFile, EOFError) as e:
        raise FilmRejected(f"its arrays cannot be read ({e})") from None
    counts = arrays["finite"].astype(np.uint64) + arrays["dropped"].astype(np.uint64)
    bad = np.argwhere(counts != spp)
    if bad.size:
        y, x = (int(v) for v in bad[0])
        raise FilmRejected(
            f"pixel ({x}, {y}) holds {int(counts[y, x])} samples (expected {spp})"
        )
    return header
