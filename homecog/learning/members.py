"""The members of a Q table's file (a zip of ``.npy`` arrays), read only as what the home needs.

An ``.npy`` member begins with a header that says its type and shape; ``numpy.load`` allocates
what the header claims before it reads a byte of the data, so a crafted header of a few bytes
(and zeros compressed a thousandfold) made ``build --q`` take 1.7 GB and 8 s before the table's
shape was found wrong. Here the header is read first and checked against the type and shape
the home needs (or, for the metadata, a bound), and only then the array.

>>> import io, zipfile
>>> buffer = io.BytesIO()
>>> with zipfile.ZipFile(buffer, "w") as z, z.open("q0.npy", "w") as f:
...     np.lib.format.write_array(f, np.zeros((3, 2), dtype=np.float16))
>>> with zipfile.ZipFile(buffer) as z:
...     read_array(z, "q0", (3, 2), np.float16, "den.npz", "group 0's table").shape
(3, 2)
>>> with zipfile.ZipFile(buffer) as z:
...     read_array(z, "q0", (4, 2), np.float16, "den.npz", "group 0's table")
Traceback (most recent call last):
...
homecog.errors.QTableError: den.npz: group 0's table is float16 of shape (3, 2); this home needs \
float16 of shape (4, 2); train again
"""

from __future__ import annotations

import json
import zipfile
from typing import Any

import numpy as np

from homecog.errors import QTableError

#: the most characters the metadata member may hold (the 1,002-device home's: about 100,000)
MAX_META_CHARS = 4 * 1024 * 1024

_HEADERS = {(1, 0): np.lib.format.read_array_header_1_0, (2, 0): np.lib.format.read_array_header_2_0}


def header(z: zipfile.ZipFile, name: str) -> tuple[tuple[int, ...], np.dtype[Any]]:
    """The shape and type the member ``name`` (``.npy``) says it holds, read from its header
    alone; ValueError for a member that is not an ``.npy`` array, KeyError for a missing one."""
    with z.open(f"{name}.npy") as f:
        read = _HEADERS.get(np.lib.format.read_magic(f))
        if read is None:
            raise ValueError(f"{name}: an .npy version this homecog does not read")
        shape, _fortran, dtype = read(f)
    return tuple(shape), dtype


def read_array(
    z: zipfile.ZipFile, name: str, shape: tuple[int, ...], dtype: Any, source: str, what: str
) -> np.ndarray:
    """The member ``name`` as an array, refused with :class:`QTableError` unless its header
    says ``dtype`` and ``shape`` (nothing allocated for another)."""
    got_shape, got = header(z, name)
    want = np.dtype(dtype)
    if got_shape != shape or got != want:
        raise QTableError(
            f"{source}: {what} is {_type(got)} of shape {_shape(got_shape)}; this home needs "
            f"{_type(want)} of shape {_shape(shape)}; train again"
        )
    with z.open(f"{name}.npy") as f:
        return np.lib.format.read_array(f, allow_pickle=False)


def read_meta(z: zipfile.ZipFile, source: str) -> dict[str, Any]:
    """The file's metadata (one text of JSON), of at most :data:`MAX_META_CHARS` characters."""
    shape, dtype = header(z, "meta")
    if shape != () or dtype.kind != "U" or dtype.itemsize > 4 * MAX_META_CHARS:
        raise QTableError(
            f"{source}: not a homecog Q table (its metadata is {_type(dtype)} of shape {_shape(shape)}; "
            f"expected one text of at most {MAX_META_CHARS:,} characters)"
        )
    with z.open("meta.npy") as f:
        text = str(np.lib.format.read_array(f, allow_pickle=False))
    try:
        meta = json.loads(text)
    except (ValueError, RecursionError):
        meta = None
    if not isinstance(meta, dict):
        raise QTableError(f"{source}: not a homecog Q table (its metadata is not a JSON object)")
    return meta


def _type(dtype: np.dtype[Any]) -> str:
    return str(dtype) if dtype.kind != "U" else f"text of {dtype.itemsize // 4:,} characters"


def _shape(shape: tuple[int, ...]) -> str:
    text = repr(tuple(int(n) for n in shape))
    return text if len(text) <= 60 else text[:59] + "…"
