"""Fuzz target for the rig exchange's NPZ reader (``addon/common/files.py: read_npz``), with
atheris (libFuzzer for Python): the reader is the add-on's, in Python, not the core's, so
cargo-fuzz cannot reach it.

Inputs are structured so that most reach the .npy headers: a zip of up to five members named
as the rig bundle's arrays, each a real ``numpy.save`` of a small array (or any bytes), its
header and data then edited (a byte changed, cut short, a claimed shape made huge), stored or
deflated, and the archive itself sometimes cut or changed. ``read_npz`` must return arrays of
the shapes and kinds the bundle asks for, or raise ``FileReadError``; anything else (another
exception, a hang, memory past libFuzzer's limit) is a finding.

    .venv/bin/python fuzz/npz.py fuzz/corpus/npz -max_total_time=60 -rss_limit_mb=2048
"""

from __future__ import annotations

import ast
import importlib.util
import io
import os
import sys
import tempfile
import warnings
import zipfile
from pathlib import Path

import atheris
import numpy as np

ROOT = Path(__file__).resolve().parents[1]

spec = importlib.util.spec_from_file_location("miniskeleton_files", ROOT / "addon/common/files.py")
files = importlib.util.module_from_spec(spec)
sys.modules["miniskeleton_files"] = files
spec.loader.exec_module(files)


def bundle_specs():
    """The rig bundle's ``_BUNDLE_ARRAYS`` and ``_BUNDLE_REQUIRED``, read from
    ``addon/skeleton/exchange.py`` itself (importing it needs bpy)."""
    tree = ast.parse((ROOT / "addon/skeleton/exchange.py").read_text())
    found = {}
    for node in tree.body:
        if isinstance(node, (ast.Assign, ast.AnnAssign)):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            for t in targets:
                if isinstance(t, ast.Name) and t.id in ("_BUNDLE_ARRAYS", "_BUNDLE_REQUIRED"):
                    code = compile(ast.Expression(node.value), "exchange.py", "eval")
                    found[t.id] = eval(code, {"ArraySpec": files.ArraySpec})  # noqa: S307 (our own source)
    return found["_BUNDLE_ARRAYS"], found["_BUNDLE_REQUIRED"]


ARRAYS, REQUIRED = bundle_specs()
NAMES = [*ARRAYS, "extra", "vertices/../x", ""]
SAMPLES = [
    np.int32(1), np.zeros((3, 3), np.float32), np.array(["a", "bb"]), np.full((3, 2), -1, np.int32),
    np.ones((3, 2), np.float32), np.array([3], np.int64), np.zeros((0, 3), np.float64), np.array([1.5]),
    np.array([[1, 2], [3, 4]], np.uint8), np.zeros((2, 2, 2), np.float32), np.array([b"x"]),
    np.array([None], dtype=object),
]
PATH = Path(tempfile.gettempdir()) / f"miniskeleton-npz-fuzz-{os.getpid()}.npz"


def npy_bytes(fdp: atheris.FuzzedDataProvider) -> bytes:
    """One member: a saved sample array, edited; or any bytes."""
    if fdp.ConsumeIntInRange(0, 7) == 0:
        return fdp.ConsumeBytes(fdp.ConsumeIntInRange(0, 256))
    buf = io.BytesIO()
    np.save(buf, SAMPLES[fdp.ConsumeIntInRange(0, len(SAMPLES) - 1)], allow_pickle=True)
    data = bytearray(buf.getvalue())
    for _ in range(fdp.ConsumeIntInRange(0, 3)):
        what = fdp.ConsumeIntInRange(0, 3)
        if what == 0 and data:   # one byte changed (header or data)
            data[fdp.ConsumeIntInRange(0, len(data) - 1)] = fdp.ConsumeIntInRange(0, 255)
        elif what == 1:           # cut short
            data = data[:fdp.ConsumeIntInRange(0, len(data))]
        elif what == 2:           # a claimed shape made large
            text = data.decode("latin-1")
            big = str(fdp.ConsumeIntInRange(0, 2**62))
            data = bytearray(text.replace("(3,", f"({big},", 1).replace("(2,", f"({big},", 1).encode("latin-1"))
        else:                     # bytes appended
            data += fdp.ConsumeBytes(fdp.ConsumeIntInRange(0, 64))
    return bytes(data)


def archive(fdp: atheris.FuzzedDataProvider) -> bytes:
    if fdp.ConsumeIntInRange(0, 15) == 0:
        return fdp.ConsumeBytes(fdp.ConsumeIntInRange(0, 4096))
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w") as zf:
        for _ in range(fdp.ConsumeIntInRange(0, 5)):
            suffix = ".npy" if fdp.ConsumeIntInRange(0, 7) else ".txt"   # not an array: left unread
            name = NAMES[fdp.ConsumeIntInRange(0, len(NAMES) - 1)] + suffix
            method = zipfile.ZIP_DEFLATED if fdp.ConsumeBool() else zipfile.ZIP_STORED
            zf.writestr(zipfile.ZipInfo(name), npy_bytes(fdp), compress_type=method)
    data = bytearray(buf.getvalue())
    if data and fdp.ConsumeIntInRange(0, 7) == 0:
        data[fdp.ConsumeIntInRange(0, len(data) - 1)] = fdp.ConsumeIntInRange(0, 255)
    if fdp.ConsumeIntInRange(0, 7) == 0:
        data = data[:fdp.ConsumeIntInRange(0, len(data))]
    return bytes(data)


def test_one(data: bytes):
    fdp = atheris.FuzzedDataProvider(data)
    PATH.write_bytes(archive(fdp))
    try:
        out = files.read_npz(PATH, "rig bundle", ARRAYS, REQUIRED)
    except files.FileReadError:
        return
    for name in REQUIRED:
        assert name in out, name
    for name, arr in out.items():
        spec = ARRAYS.get(name)
        assert arr.dtype.kind != "O", name
        if spec is not None:
            assert arr.ndim == spec.ndim, (name, arr.shape)
            assert spec.columns is None or arr.shape[-1] == spec.columns, (name, arr.shape)
            assert arr.dtype.kind in spec.kinds, (name, arr.dtype)


if __name__ == "__main__":
    warnings.simplefilter("ignore")   # zipfile's "Duplicate name", numpy's header remarks
    atheris.instrument_all()          # the reader, and zipfile, zlib's wrapper and numpy's header parser
    atheris.Setup(sys.argv, test_one)
    try:
        atheris.Fuzz()
    finally:
        PATH.unlink(missing_ok=True)
