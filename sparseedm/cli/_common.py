"""Options and helpers shared by the sub-commands."""

from __future__ import annotations

import sys
import zipfile
from pathlib import Path


def add_quiet(parser):
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="no progress bar (it is also off when stderr is not a terminal)")


def show_progress(args) -> bool:
    """Progress bars only for a person watching a terminal."""
    return not getattr(args, "quiet", False) and sys.stderr.isatty()


def load_npz(path, what, required, optional=()):
    """The `required` and present `optional` arrays of an .npz (pickles refused).

    Returns ``(arrays, names)``: a dict of the arrays read and the set of all
    array names in the file. Raises FileNotFoundError or FileFormatError
    naming the file.
    """
    import numpy as np

    from ..exceptions import FileFormatError

    path = Path(path)
    if not path.is_file():
        raise FileNotFoundError(f"no such {what} file: {path}")
    try:
        with np.load(path, allow_pickle=False) as npz:
            names = set(npz.files)
            lacking = [k for k in required if k not in names]
            if lacking:
                raise FileFormatError(
                    f"{path}: no {' or '.join(map(repr, lacking))} array (has: "
                    f"{', '.join(sorted(names)) or 'nothing'}); see `sparseedm dataset build`")
            arrays = {k: npz[k] for k in (*required, *optional) if k in names}
    except FileFormatError:
        raise
    except ValueError as exc:
        raise FileFormatError(f"{path}: unreadable .npz or one holding pickles ({exc})") from None
    except (OSError, EOFError, zipfile.BadZipFile) as exc:
        raise FileFormatError(f"{path}: not an .npz file ({exc})") from None
    return arrays, names
