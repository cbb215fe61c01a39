"""Reading a motion-capture text file: size limit, strict UTF-8, errors naming the line."""

from __future__ import annotations

import os

from .._safeio import regular_file
from ..exceptions import FileFormatError

_BOM = b"\xef\xbb\xbf"

#: files larger than this are refused before reading (bytes); raise it for
#: genuinely long takes (``sparseedm.mocap.MAX_FILE_BYTES = ...``)
MAX_FILE_BYTES = 1 << 30


def read_text(source, name=None) -> tuple[list[str], str]:
    """(lines, name) of a path, or of text given directly (containing a newline).

    Raises
    ------
    FileFormatError
        A file over :data:`MAX_FILE_BYTES`, a folder, device or pipe, or bytes
        that are not UTF-8 text (the message names the line). A UTF-8
        byte-order mark at the start is dropped.
    """
    if isinstance(source, os.PathLike) or (isinstance(source, str) and "\n" not in source):
        path = os.fspath(source)
        from . import MAX_FILE_BYTES as limit  # the package attribute users may change

        size = regular_file(path, path)  # /dev/zero would be read until memory runs out
        try:
            if size > limit:
                raise FileFormatError(
                    f"{path}: {size / 2**20:.0f} MiB is larger than the {limit / 2**20:.0f} MiB "
                    "limit for one motion file (set sparseedm.mocap.MAX_FILE_BYTES to allow it)")
            with open(path, "rb") as fh:
                data = fh.read(limit + 1)
            if data.startswith(_BOM):  # editors on Windows write one; it is not text
                data = data[len(_BOM):]
        except FileNotFoundError:
            raise
        except OSError as exc:  # a folder, no permission ...
            raise FileFormatError(f"{path}: cannot read it ({exc.strerror or exc})") from None
        try:
            text = data.decode("utf-8")
        except UnicodeDecodeError as exc:
            line = data.count(b"\n", 0, exc.start) + 1
            raise FileFormatError(
                f"{path}, line {line}: byte 0x{data[exc.start]:02x} is not UTF-8 text "
                "(a binary or corrupted file?)") from None
        return text.splitlines(), path
    return str(source).splitlines(), name or "<string>"
