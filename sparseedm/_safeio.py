"""Bounded readers for files users hand us: the work is checked before it is done.

A hostile or broken file must give a clear :class:`FileFormatError`, never a
20 TiB allocation, an endless read or a traceback. Every reader of sparseedm
goes through these:

:func:`load_npy`, :func:`load_npz`
    The ``.npy`` header (or each wanted ``.npz`` member's header) is parsed
    first; its declared size (shape x itemsize) must fit in the bytes that
    follow it (the file size, or the member's decompressed size that the zip
    directory declares and zipfile enforces), under an optional cap and under
    the memory available, before anything is allocated. Object dtypes (pickles) are refused, never loaded.
    Only the members asked for are read: others are never decompressed.
:func:`text_lines`
    Lines of a UTF-8 text file (a leading BOM dropped), each capped at
    :data:`MAX_LINE_BYTES` while it is read (an endless line from
    ``/dev/zero`` stops at the cap); a decoding error names the byte offset.
:func:`load_json`
    A JSON document of at most :data:`MAX_JSON_BYTES`, nesting at most
    :data:`MAX_JSON_DEPTH` deep, integers of at most :data:`MAX_INT_DIGITS`
    digits.

Examples
--------
>>> import os, tempfile
>>> import numpy as np
>>> path = os.path.join(tempfile.mkdtemp(), "a.npy")
>>> np.save(path, np.zeros((2, 3)))
>>> load_npy(path).shape
(2, 3)
>>> with open(path, "r+b") as f:                  # a header claiming 10**12 rows
...     data = f.read().replace(b"(2, 3), }", b"(1000000000000, 3), }")
...     _ = f.seek(0); _ = f.write(data)
>>> load_npy(path)  # doctest: +ELLIPSIS
Traceback (most recent call last):
...
sparseedm.exceptions.FileFormatError: ...a.npy: the header declares shape (1000000000000, 3) of float64 (24000000000000 bytes) but only ... bytes follow it: truncated or corrupt file
"""

from __future__ import annotations

import json
import math
import os
import re
import stat
import warnings
import zipfile
from pathlib import Path

import numpy as np

from .exceptions import FileFormatError, PickledDataError

__all__ = ["load_npy", "load_npz", "text_lines", "regular_file", "require_file", "available_memory", "load_json", "MAX_LINE_BYTES",
           "MAX_JSON_BYTES", "MAX_JSON_DEPTH", "MAX_INT_DIGITS"]

#: longest line a text reader accepts (a keypoint CSV row is ~1 kB)
MAX_LINE_BYTES = 1 << 20
#: largest JSON document read into memory
MAX_JSON_BYTES = 1 << 30
#: deepest JSON nesting accepted (COCO files need 5)
MAX_JSON_DEPTH = 64
#: longest integer literal accepted in JSON
MAX_INT_DIGITS = 40
_MAX_HEADER = 10_000  # numpy's own default cap on .npy header size
_BOM = b"\xef\xbb\xbf"
_NUL = b"\x00"


def _regular_file(path, what):
    """The size of `path`, which must be a regular file."""
    try:
        st = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        raise FileNotFoundError(f"{path}: no such file") from None
    except OSError as exc:
        raise FileFormatError(f"{what} cannot be opened ({exc.strerror})") from None
    if stat.S_ISDIR(st.st_mode):
        raise FileFormatError(f"{what} is a directory, not a file")
    if not stat.S_ISREG(st.st_mode):
        raise FileFormatError(f"{what} is not a regular file (a device, pipe or socket)")
    return st.st_size


def regular_file(path, what=None) -> int:
    """The size of `path`; a missing path raises FileNotFoundError, a folder,
    device, pipe or socket a FileFormatError saying which (never "missing").

    Examples
    --------
    >>> regular_file("/dev/null", "dictionary /dev/null")
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.FileFormatError: dictionary /dev/null is not a regular file (a device, pipe or socket)
    """
    return _regular_file(path, what or str(path))


def require_file(path, what, error):
    """:func:`regular_file` raising `error` (e.g. DictionaryError) for a path that
    is missing ("no such <what> file") or not a regular file (which it is)."""
    try:
        return regular_file(path, f"{what} {path}")
    except FileNotFoundError:
        raise error(f"{path}: no such {what} file") from None
    except FileFormatError as exc:
        raise error(str(exc)) from None


def _read_header(f, what):
    """(shape, fortran_order, dtype) of the .npy stream `f`, positioned after it."""
    try:
        with warnings.catch_warnings():  # numpy re-parses Python 2 headers, with a warning
            warnings.simplefilter("ignore", UserWarning)
            return _parse_header(f, what)
    except FileFormatError:
        raise
    except Exception as exc:  # noqa: BLE001 - numpy parses the header with ast/tokenize
        raise FileFormatError(
            f"{what} is not a valid .npy array ({type(exc).__name__}: {exc})") from None


def _parse_header(f, what):
    version = np.lib.format.read_magic(f)
    if version == (1, 0):
        header = np.lib.format.read_array_header_1_0(f, max_header_size=_MAX_HEADER)
    elif version == (2, 0):
        header = np.lib.format.read_array_header_2_0(f, max_header_size=_MAX_HEADER)
    elif version == (3, 0):  # utf-8 field names; numpy keeps its reader private
        from numpy.lib import _format_impl
        header = _format_impl._read_array_header(f, version, max_header_size=_MAX_HEADER)
    else:
        raise ValueError(f"unsupported .npy format version {version[0]}.{version[1]}")
    shape, fortran, dtype = header
    if dtype.hasobject:
        raise PickledDataError(
            f"{what} holds pickled Python objects, which sparseedm refuses to load "
            "(they can run code); save plain numeric/string arrays"
        )
    return shape, fortran, dtype


def _declared(shape, dtype):
    return math.prod(int(d) for d in shape) * dtype.itemsize


def _free_memory():
    """MemAvailable in bytes (Linux), else None."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    return None


def available_memory():
    """Memory this machine has available now, in bytes (Linux's MemAvailable), or None."""
    return _free_memory()


def _check_size(shape, dtype, available, what, max_bytes, in_memory=True):
    nbytes = _declared(shape, dtype)
    if nbytes > available:
        raise FileFormatError(
            f"{what}: the header declares shape {tuple(shape)} of {dtype} ({nbytes} bytes) "
            f"but only {available} bytes follow it: truncated or corrupt file"
        )
    free = _free_memory() if in_memory else None
    if free is not None and nbytes > free:  # an honest zip bomb, or simply too big
        raise FileFormatError(
            f"{what}: shape {tuple(shape)} of {dtype} needs {nbytes} bytes of memory; "
            f"only {free} are available"
        )
    if max_bytes is not None and nbytes > max_bytes:
        raise FileFormatError(
            f"{what}: shape {tuple(shape)} of {dtype} ({nbytes} bytes) is larger than "
            f"the {max_bytes} bytes this array may hold"
        )


def _guard(read, what):
    try:
        return read()
    except FileFormatError:
        raise
    except (ValueError, OSError, EOFError, zipfile.BadZipFile, MemoryError,
            OverflowError, TypeError) as exc:
        raise FileFormatError(f"{what} is not readable ({type(exc).__name__}: {exc})") from None


def load_npy(path, *, mmap_mode=None, max_bytes=None, what=None):
    """A single ``.npy`` array, its declared size checked against the file first."""
    what = what or f"{path}:"
    size = _regular_file(path, what)

    def header():
        with open(path, "rb") as f:
            shape, _, dtype = _read_header(f, what)
            return shape, dtype, size - f.tell()

    shape, dtype, available = _guard(header, what)
    _check_size(shape, dtype, available, str(path), max_bytes, in_memory=mmap_mode is None)
    if mmap_mode is not None and _declared(shape, dtype) == 0:
        mmap_mode = None  # numpy cannot map an empty array
    return _guard(lambda: np.load(path, mmap_mode=mmap_mode, allow_pickle=False), what)


def _refuse_pickle_file(path, what):
    """A whole-file pickle (protocol 2+ starts with 0x80) is named as such, never read."""
    with open(path, "rb") as f:
        head = f.read(2)
    if len(head) == 2 and head[0] == 0x80 and head[1] <= 5:
        raise PickledDataError(
            f"{what} is a Python pickle, which sparseedm refuses to load (it can run code)")


def npz_members(path, what=None):
    """Names of the arrays an ``.npz`` holds (nothing is decompressed)."""
    what = what or f"{path}:"
    _regular_file(path, what)

    def names():
        with zipfile.ZipFile(path) as zf:
            return [n[:-4] for n in zf.namelist() if n.endswith(".npy")]

    return _guard(names, what)


def load_npz(path, keys, *, max_bytes=None, what=None):
    """The members `keys` of an ``.npz`` (those present), each bounded before it is read.

    Parameters
    ----------
    keys : iterable of str
        Array names wanted; others are never decompressed.
    max_bytes : int or dict of str -> int, optional
        A cap on each array's size in memory.

    Returns
    -------
    arrays : dict of str -> ndarray
    names : list of str
        Every array name in the archive.
    """
    what = what or f"{path}:"
    _regular_file(path, what)
    keys = list(keys)
    _refuse_pickle_file(path, what)

    def read():
        arrays = {}
        with zipfile.ZipFile(path) as zf:
            infos = {i.filename[:-4]: i for i in zf.infolist() if i.filename.endswith(".npy")}
            for key in keys:
                info = infos.get(key)
                if info is None:
                    continue
                where = f"{path}: array {key!r}"
                with zf.open(info) as f:
                    shape, _, dtype = _read_header(f, where)
                    offset = f.tell()
                cap = max_bytes.get(key) if isinstance(max_bytes, dict) else max_bytes
                _check_size(shape, dtype, info.file_size - offset, where, cap)
                with zf.open(info) as f:
                    arrays[key] = _guard(
                        lambda: np.lib.format.read_array(f, allow_pickle=False,
                                                         max_header_size=_MAX_HEADER),
                        where)
        return arrays, list(infos)

    return _guard(read, what)


def load_npz_file(path, keys, *, error, kind, max_bytes=None):
    """:func:`load_npz` for one of our own file kinds: every refusal is `error`.

    A pickle is refused as such ("holds pickled data, which is refused (never
    executed)"), any other read problem is "corrupt or truncated <kind> file",
    both naming `path`. `keys` may be a callable, given the archive's member
    names, that returns the keys to read. Shared by the dictionary, lifter and
    FConv model loaders.
    """
    try:
        _refuse_pickle_file(path, f"{path}:")  # a whole-file pickle, before the zip is read
        if callable(keys):
            keys = keys(npz_members(path))
        return load_npz(path, keys, max_bytes=max_bytes)
    except FileFormatError as exc:
        if isinstance(exc, PickledDataError):
            raise error(f"{path}: holds pickled data, which is refused (never executed)"
                        ) from None
        raise error(f"corrupt or truncated {kind} file: {exc}") from None


def parse_meta(text, path, *, error, parse_int=None):
    """The JSON object in a file's 0-d string array ``meta``; problems raise `error`."""
    if text.dtype.kind != "U" or text.ndim != 0:
        raise error(f"{path}: meta must be a 0-d string array holding JSON")
    try:
        meta = json.loads(str(text), parse_int=parse_int)
    except (json.JSONDecodeError, RecursionError, ValueError) as exc:
        raise error(f"{path}: metadata is not valid JSON ({exc})") from None
    if not isinstance(meta, dict):
        raise error(f"{path}: metadata must be a JSON object, got {type(meta).__name__}")
    return meta


def text_lines(path, *, max_line_bytes=MAX_LINE_BYTES):
    """Yield ``(line_number, text)`` of a UTF-8 file, bounded per line.

    A UTF-8 byte-order mark at the start is dropped. A line longer than
    `max_line_bytes`, or bytes that are not UTF-8, raise
    :class:`FileFormatError` naming the file, line and byte offset.
    """
    offset = 0
    with open(path, "rb") as f:
        for number in range(1, 1 << 62):
            raw = f.readline(max_line_bytes + 1)
            if not raw:
                return
            if len(raw) > max_line_bytes:
                raise FileFormatError(
                    f"{path}, line {number} (byte {offset}): longer than {max_line_bytes} "
                    "bytes; not a keypoint text file"
                )
            body = raw[len(_BOM):] if number == 1 and raw.startswith(_BOM) else raw
            start = offset + len(raw) - len(body)
            try:
                text = body.decode("utf-8")
            except UnicodeDecodeError as exc:
                raise FileFormatError(
                    f"{path}, line {number}, byte {start + exc.start}: not UTF-8 text "
                    f"({exc.reason}); save the file as UTF-8"
                ) from None
            if "\x00" in text:
                raise FileFormatError(
                    f"{path}, line {number}, byte {start + body.index(_NUL)}: a NUL byte; "
                    "not a text file"
                )
            offset += len(raw)
            yield number, text


_TOKENS = re.compile(rb'"(?:[^"\\]|\\.)*"|[\[\]{}]')


def _depth(data: bytes) -> int:
    depth = deepest = 0
    for m in _TOKENS.finditer(data):
        t = m.group()
        if t in (b"[", b"{"):
            depth += 1
            deepest = max(deepest, depth)
        elif t in (b"]", b"}"):
            depth -= 1
    return deepest


def load_json(path, *, max_bytes=MAX_JSON_BYTES, max_depth=MAX_JSON_DEPTH,
              max_int_digits=MAX_INT_DIGITS):
    """Parse a UTF-8 JSON file with its size, nesting depth and integers bounded."""
    chunks, total = [], 0
    with open(path, "rb") as f:
        while True:
            chunk = f.read(1 << 20)
            if not chunk:
                break
            if _NUL in chunk:
                raise FileFormatError(
                    f"{path}, byte {total + chunk.index(_NUL)}: a NUL byte; not JSON text")
            total += len(chunk)
            if total > max_bytes:
                raise FileFormatError(f"{path}: larger than {max_bytes} bytes; refused")
            chunks.append(chunk)
    data = b"".join(chunks)
    start = len(_BOM) if data.startswith(_BOM) else 0
    try:
        text = data[start:].decode("utf-8")
    except UnicodeDecodeError as exc:
        raise FileFormatError(
            f"{path}, byte {start + exc.start}: not UTF-8 text ({exc.reason}); save the "
            "file as UTF-8"
        ) from None
    deepest = _depth(data)
    if deepest > max_depth:
        raise FileFormatError(
            f"{path}: JSON nested {deepest} levels deep; at most {max_depth} are accepted")

    def parse_int(s):
        if len(s.lstrip("-")) > max_int_digits:
            raise FileFormatError(
                f"{path}: an integer of {len(s.lstrip('-'))} digits; at most "
                f"{max_int_digits} are accepted")
        return int(s)

    try:
        return json.loads(text, parse_int=parse_int)
    except json.JSONDecodeError as exc:
        raise FileFormatError(
            f"{path}: invalid or truncated JSON at line {exc.lineno}, column "
            f"{exc.colno}: {exc.msg}"
        ) from None
    except RecursionError:
        raise FileFormatError(f"{path}: JSON nested too deeply") from None


def resolved(path) -> Path:
    """`path` made absolute with symlinks resolved (for comparing paths)."""
    return Path(os.path.abspath(Path(path).expanduser())).resolve()
