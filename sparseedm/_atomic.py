"""Atomic file writes: a crash, Ctrl-C or SIGTERM never leaves a half-written output.

:func:`atomic_path` yields a temporary path beside the target and renames it
over the target on success. Temporary files are named
``.<name>.sparseedm-tmp-<pid>-<random><suffix>``: while one exists, SIGTERM,
SIGHUP and SIGINT (when Python's own Ctrl-C handler is not installed) remove it
before the previous handler runs, and a later write to the same target removes
the leftovers of writers that were killed outright (SIGKILL, power loss): the
``<pid>`` in the name is no longer running.

:func:`check_paths` refuses an output that is an input, another output, a
directory, or under a parent that is a regular file, before any work is done.
"""

from __future__ import annotations

import contextlib
import os
import re
import signal
import tempfile
import threading
from pathlib import Path

from .exceptions import OutputPathError

__all__ = ["atomic_path", "check_paths", "save_npz", "save_npy", "remove_leftovers", "TEMP_MARK"]

#: every temporary file's name holds this (see the module docstring)
TEMP_MARK = ".sparseedm-tmp-"
_LEFTOVER = re.compile(r"^\.(?P<name>.+)" + re.escape(TEMP_MARK) + r"(?P<pid>\d+)-")
_SIGNALS = tuple(getattr(signal, s) for s in ("SIGTERM", "SIGHUP", "SIGINT")
                 if hasattr(signal, s))

_live: set[str] = set()        # temporary files of writes in progress
_previous: dict = {}           # signal -> handler before ours
_lock = threading.Lock()


def _remove_live():
    for tmp in list(_live):
        with contextlib.suppress(OSError):
            os.unlink(tmp)
        _live.discard(tmp)


def _on_signal(signum, frame):
    previous = _previous.get(signum, signal.SIG_DFL)
    if signum == getattr(signal, "SIGINT", None) and previous is signal.default_int_handler:
        raise KeyboardInterrupt  # unwinding removes the files (and lets callers react)
    _remove_live()
    _restore()
    if callable(previous):
        previous(signum, frame)
    elif previous == signal.SIG_DFL:
        os.kill(os.getpid(), signum)  # die of it, as without us


def _install():
    if threading.current_thread() is not threading.main_thread() or _previous:
        return
    for signum in _SIGNALS:
        try:
            old = signal.getsignal(signum)
            if old is signal.SIG_IGN or old is None:
                continue
            signal.signal(signum, _on_signal)
            _previous[signum] = old
        except (ValueError, OSError):  # pragma: no cover - not the main thread
            pass


def _restore():
    if threading.current_thread() is not threading.main_thread():
        return
    for signum, old in list(_previous.items()):
        with contextlib.suppress(ValueError, OSError, TypeError):
            if signal.getsignal(signum) is _on_signal:
                signal.signal(signum, old)
        del _previous[signum]


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except OSError:
        return True  # exists, owned by someone else
    return True


def remove_leftovers(path) -> list[Path]:
    """Remove temporary files that killed writers left beside `path`; return them."""
    path = Path(path)
    removed = []
    with contextlib.suppress(OSError):
        for entry in os.scandir(path.parent):
            m = _LEFTOVER.match(entry.name)
            if not m or m.group("name") != path.name or not entry.is_file(follow_symlinks=False):
                continue
            if not _pid_alive(int(m.group("pid"))):
                with contextlib.suppress(OSError):
                    os.unlink(entry.path)
                    removed.append(Path(entry.path))
    return removed


def _parent_ok(path: Path):
    for parent in (path.parent, *path.parent.parents):
        if parent.exists():
            if not parent.is_dir():
                raise OutputPathError(
                    f"{path}: cannot create it: {parent} is a file, not a directory")
            return


def check_paths(inputs=(), outputs=()):
    """Refuse outputs that would overwrite an input or each other, before any work.

    Paths are compared resolved (``..``, symlinks) and, when both exist, with
    :func:`os.path.samefile` (hard links). An output that is a directory, or
    whose parent is a regular file, is refused too.

    Parameters
    ----------
    inputs : iterable of (label, path)
    outputs : iterable of (label, path)

    Raises
    ------
    OutputPathError

    Examples
    --------
    >>> check_paths([("input", "in.csv")], [("-o", "sub/../in.csv")])
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.OutputPathError: -o sub/../in.csv is the input in.csv: refusing to overwrite it
    """
    inputs = [(label, Path(p)) for label, p in inputs if p is not None]
    outputs = [(label, Path(p)) for label, p in outputs if p is not None]

    def same(a, b):
        if os.path.abspath(a) == os.path.abspath(b):
            return True
        with contextlib.suppress(OSError, ValueError):
            if a.resolve() == b.resolve():
                return True
            if a.exists() and b.exists():
                return os.path.samefile(a, b)
        return False

    for k, (label, out) in enumerate(outputs):
        for in_label, src in inputs:
            if same(out, src):
                raise OutputPathError(
                    f"{label} {out} is the {in_label} {src}: refusing to overwrite it")
        for other_label, other in outputs[:k]:
            if same(out, other):
                raise OutputPathError(
                    f"{label} {out} and {other_label} {other} are the same file: "
                    "give them different names")
        if out.is_dir():
            raise OutputPathError(f"{label} {out} is a directory; give a file name")
        _parent_ok(out)


@contextlib.contextmanager
def atomic_path(path, suffix=None):
    """Yield a temporary path beside `path`; rename it over `path` on success.

    The temporary file keeps `path`'s suffix (or `suffix`). On any exception,
    and on SIGTERM/SIGHUP, the temporary file is removed and `path` is
    untouched. Leftovers of killed earlier writers to `path` are removed first.
    Write through an open file object (``np.save(f, ...)``), not a file name:
    numpy appends ``.npy``/``.npz`` to names without that extension.

    Examples
    --------
    >>> import numpy as np, tempfile, os
    >>> d = tempfile.mkdtemp()
    >>> with atomic_path(os.path.join(d, "a.npz")) as tmp:
    ...     np.savez(tmp, x=np.arange(3))
    >>> sorted(os.listdir(d))
    ['a.npz']
    """
    path = Path(path)
    _parent_ok(path)
    if path.is_dir():
        raise OutputPathError(f"{path} is a directory; give a file name")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(f"{path}: cannot create its folder ({exc.strerror})") from None
    remove_leftovers(path)
    try:
        fd, tmp = tempfile.mkstemp(
            prefix=f".{path.name}{TEMP_MARK}{os.getpid()}-",
            suffix=suffix or "".join(path.suffixes) or ".tmp", dir=path.parent,
        )
    except OSError as exc:
        raise OutputPathError(f"{path}: cannot write beside it ({exc.strerror})") from None
    os.close(fd)
    with _lock:
        if not _live:
            _install()
        _live.add(tmp)
    umask = os.umask(0)
    os.umask(umask)
    os.chmod(tmp, 0o666 & ~umask)  # mkstemp makes 0600: give the usual mode
    try:
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    finally:
        with _lock:
            _live.discard(tmp)
            if not _live:
                _restore()


def save_npz(path, arrays, *, compressed=False):
    """Write `arrays` as an ``.npz`` at exactly `path` (whatever its extension), atomically."""
    import numpy as np

    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            (np.savez_compressed if compressed else np.savez)(f, **arrays)
    return Path(path)


def save_npy(path, array):
    """Write one array as ``.npy`` at exactly `path`, atomically."""
    import numpy as np

    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            np.save(f, array)
    return Path(path)
