"""Files the operators write and read: the folder an export or a video goes in, a file that
takes another's place only once it is whole, and NumPy ``.npz`` archives read with every
header checked before any data is trusted or allocated."""

from __future__ import annotations

import math
import os
import struct
import tokenize
import warnings
import zipfile
import zlib
from collections import Counter
from pathlib import Path
from typing import NamedTuple

import numpy as np
from numpy.lib import format as npy_format

try:   # optional in a Python build; zipfile then refuses LZMA members with NotImplementedError
    from lzma import LZMAError
except ImportError:   # pragma: no cover
    LZMAError = OSError

# What one .npz may hold, over all its arrays: 100 million elements in at most 1 GiB (a rig
# bundle of some 4 million vertices with 8 bones each), in at most 1000 arrays.
NPZ_MAX_ELEMENTS = 100_000_000
NPZ_MAX_BYTES = 1 << 30
NPZ_MAX_ARRAYS = 1000
_CHUNK = 1 << 24   # data is read 16 MiB at a time into the array it fills

# What reading untrusted bytes through zipfile, zlib and numpy's header parser raises: damaged
# or truncated data (zlib.error, LZMAError, EOFError, BadZipFile for a bad CRC or a bad
# directory, struct.error), zip features numpy never writes (NotImplementedError "strong
# encryption", RuntimeError "password required"), headers that are no Python literal
# (SyntaxError, ValueError, TypeError for an unhashable key, MemoryError or RecursionError for
# deep nesting, tokenize.TokenError from numpy's fallback parser), names that are no text
# (UnicodeDecodeError) and the file system (OSError). Programming errors (AttributeError,
# NameError, ...) are not in the list.
_READ_ERRORS = (OSError, EOFError, ValueError, SyntaxError, TypeError, LookupError, ArithmeticError,
                MemoryError, RuntimeError, zipfile.BadZipFile, zlib.error, LZMAError, struct.error,
                tokenize.TokenError)


class FileReadError(ValueError):
    """A file that cannot be read, its message naming the file and the reason."""


class _Unfit(ValueError):
    """An array that is read well but is not what the reader asked for (``ArraySpec``)."""


class ArraySpec(NamedTuple):
    """What one array of an .npz must be, checked on its header before its data is read:
    ``ndim`` dimensions, ``columns`` in the last one (None: any), a dtype kind in ``kinds``
    ("f" float, "i"/"u" integer, "U"/"S" text), described as ``says`` in the error."""
    ndim: int
    columns: int | None
    kinds: str
    says: str


def make_folder(path: Path) -> str | None:
    """Make the folder the file ``path`` goes in (and its parents): None, or why it cannot be
    written there (for the exports' and Make Video's reports). A name the file system refuses
    (too long) fails the checks themselves: that is a reason too, not a traceback."""
    try:
        if path.is_dir():
            return "it is a folder"
        blocker = next((p for p in path.parents if p.exists()), None)
        if blocker is not None and not blocker.is_dir():
            return f"'{blocker}' is a file, not a folder"
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as err:
        return err.strerror or str(err)
    return None


def part_path(path: Path) -> Path:
    """A file beside ``path`` to write first and move onto it (``os.replace``, atomic in one
    folder) once it is whole: hidden, named after ``path`` and this process, with ``path``'s
    extension (writers such as Blender's movie output go by it)."""
    return path.with_name(f".{path.stem}.part-{os.getpid()}{path.suffix}")


def read_npz(path: Path, what: str = "file", arrays: dict[str, ArraySpec] | None = None,
             required: tuple[str, ...] = ()) -> dict[str, np.ndarray]:
    """Every array of the NumPy archive ``path`` ({name: array}, names without ".npy"), read
    only after all of it has been checked; FileReadError (naming ``what``, the file and the
    reason) otherwise. Checked first, from the zip directory and each array's .npy header
    (``numpy.lib.format``), before any array is allocated: the ``required`` names are there;
    each array's shape and dtype match ``arrays`` (by name; others: any shape); no array holds
    Python objects (pickles are never loaded); together they stay within ``NPZ_MAX_ELEMENTS``
    elements, ``NPZ_MAX_BYTES`` bytes and ``NPZ_MAX_ARRAYS`` arrays; and each header's shape
    and dtype account for exactly the bytes its member holds. Then the data is read, and its
    checksum checked, into arrays of the checked size. Zip members not ending in ".npy" are
    not arrays and are left unread."""
    arrays = arrays or {}
    member = ""
    try:
        with open(path, "rb") as fh:
            if not zipfile.is_zipfile(fh):
                raise FileReadError(f"'{path}' is not an .npz {what} (not a zip of arrays, "
                                    "or one cut short)")
            fh.seek(0)
            with zipfile.ZipFile(fh) as zf:
                infos = [i for i in zf.infolist() if i.filename.endswith(".npy")]
                if len(infos) > NPZ_MAX_ARRAYS:
                    raise FileReadError(f"{what} '{path}' holds {len(infos)} arrays, more than the "
                                        f"{NPZ_MAX_ARRAYS} an .npz may hold here")
                keys = [i.filename[:-4] for i in infos]
                twice = sorted(k for k, count in Counter(keys).items() if count > 1)
                if twice:
                    raise FileReadError(f"{what} '{path}' holds the array '{twice[0]}' twice")
                missing = [k for k in required if k not in keys]
                if missing:
                    raise _Unfit(f"missing {', '.join(missing)}")
                headers = []
                elements = size = 0
                for info in infos:
                    member = info.filename
                    header = _npy_header(zf, info, arrays.get(member[:-4]))
                    elements += header[3]
                    size += header[4]
                    if elements > NPZ_MAX_ELEMENTS or size > NPZ_MAX_BYTES:
                        raise ValueError(f"its header claims {header[0]} {header[2]}: with the arrays "
                                         f"before it more than the {NPZ_MAX_ELEMENTS:,} elements and "
                                         f"{NPZ_MAX_BYTES >> 20} MiB an .npz may hold here")
                    headers.append(header)
                out = {}
                for info, header in zip(infos, headers):
                    member = info.filename
                    out[member[:-4]] = _npy_data(zf, info, *header)
                return out
    except FileReadError:
        raise
    except _Unfit as err:
        raise FileReadError(f"{what} '{path}' cannot be used: {err}") from err
    except _READ_ERRORS as err:
        where = f"array '{member[:-4]}': " if member else ""
        raise FileReadError(f"cannot read {what} '{path}': {where}{_why(err)}") from err


def _why(err: BaseException) -> str:
    """The reason for a read error, in words where the exception has none, at most 200
    characters (a header that cannot be parsed is quoted whole, up to 10 000)."""
    if isinstance(err, (zlib.error, LZMAError)):
        reason = f"its compressed data is damaged ({err})"
    elif isinstance(err, (SyntaxError, tokenize.TokenError)):
        reason = f"its .npy header cannot be parsed ({err.args[0] if err.args else type(err).__name__})"
    elif isinstance(err, EOFError):
        reason = f"it ends early ({err})" if str(err) else "it ends early (the file is cut short)"
    else:
        reason = str(err) or type(err).__name__
    return reason if len(reason) <= 200 else reason[:200] + " ..."


def _npy_header(zf: zipfile.ZipFile, info: zipfile.ZipInfo, spec: ArraySpec | None):
    """(shape, fortran order, dtype, elements, bytes, data offset) of one .npy member, read
    from its header alone and checked (``read_npz``); ValueError with the reason."""
    if info.flag_bits & 0x1:
        raise ValueError("it is encrypted (an .npz never is)")
    with zf.open(info) as m, warnings.catch_warnings():
        warnings.simplefilter("ignore")   # "created on Python 2": its header is re-parsed
        version = npy_format.read_magic(m)
        if version == (1, 0):
            shape, fortran, dtype = npy_format.read_array_header_1_0(m)
        elif version == (2, 0):
            shape, fortran, dtype = npy_format.read_array_header_2_0(m)
        else:
            raise ValueError(f".npy format version {version[0]}.{version[1]} is not read here")
        offset = m.tell()
    if dtype.hasobject:
        raise ValueError("it holds Python objects (pickled data), which are never loaded")
    if dtype.subdtype is not None:
        raise ValueError(f"its dtype {dtype} is an array itself")
    if any(d < 0 for d in shape):
        raise ValueError(f"its header claims the shape {shape}")
    if spec is not None and (len(shape) != spec.ndim or dtype.kind not in spec.kinds
                             or (spec.columns is not None and shape[-1] != spec.columns)):
        raise _Unfit(f"{info.filename[:-4]} must be {spec.says}, got {dtype} {shape}")
    elements = math.prod(shape)
    size = elements * dtype.itemsize
    # An empty array may still claim 2**31 rows of nothing, which its readers would loop over.
    if math.prod(max(d, 1) for d in shape) > NPZ_MAX_ELEMENTS or size > NPZ_MAX_BYTES:
        raise ValueError(f"its header claims {shape} {dtype}, more than the {NPZ_MAX_ELEMENTS:,} "
                         f"elements and {NPZ_MAX_BYTES >> 20} MiB an .npz may hold here")
    if offset + size != info.file_size:
        raise ValueError(f"its header claims {shape} {dtype} ({size} bytes), but it holds "
                         f"{info.file_size - offset} bytes of data")
    return shape, fortran, dtype, elements, size, offset


def _npy_data(zf: zipfile.ZipFile, info: zipfile.ZipInfo, shape, fortran, dtype, elements, size, offset):
    """The array of one .npy member whose header ``_npy_header`` checked: its ``size`` bytes
    read in chunks into an array of that size, then the member's end (and so its CRC)."""
    arr = np.empty(elements, dtype=dtype)
    flat = arr.view(np.uint8) if size else None
    with zf.open(info) as m:
        if len(m.read(offset)) != offset:
            raise EOFError("it ends inside its header")
        done = 0
        while done < size:
            chunk = m.read(min(_CHUNK, size - done))
            if not chunk:
                raise EOFError(f"its data ends after {done} of {size} bytes")
            flat[done:done + len(chunk)] = np.frombuffer(chunk, dtype=np.uint8)
            done += len(chunk)
        if m.read(1):
            raise ValueError(f"it holds more than the {size} bytes its header claims")
    if dtype.kind == "U" and size:
        # Each character is a 32-bit code; one past U+10FFFF makes numpy's str() raise
        # SystemError, and a lone surrogate is not text (it cannot be encoded as UTF-8).
        codes = arr.astype(dtype.newbyteorder("=")).view(np.uint32)
        if ((codes > 0x10FFFF) | ((codes >= 0xD800) & (codes <= 0xDFFF))).any():
            raise ValueError("its strings hold codes that are not Unicode characters")
    return arr.reshape(shape, order="F" if fortran else "C")
