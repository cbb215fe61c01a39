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

Only regular files are ever replaced. A target that exists and is a character
device or a named pipe (``/dev/null``, ``/dev/stdout``, a FIFO a reader waits
on), or a symlink to one, is written *through*: the finished temporary (made
in the system's temporary folder) is streamed into it, and the device or pipe
stays what it was. A symlink to a regular file is kept: its target is
replaced atomically. A block device or a socket is refused with an
:class:`~sparseedm.exceptions.OutputPathError`, and :func:`check_paths`
refuses any output inside the files shipped with the package.
"""

from __future__ import annotations

import contextlib
import os
import re
import shutil
import signal
import stat
import tempfile
import threading
from pathlib import Path

from .exceptions import OutputPathError

__all__ = ["atomic_path", "check_paths", "is_stream", "save_npz", "save_npy",
           "remove_leftovers", "TEMP_MARK"]

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


def _temp_stem(name: str) -> str:
    """`name` as it appears in its temporaries' names: shortened (with a hash of the
    whole) when the temporary's name would pass the file systems' limit."""
    if len(os.fsencode(name)) <= _NAME_MAX - 64:
        return name
    import hashlib

    digest = hashlib.sha256(os.fsencode(name)).hexdigest()[:12]
    return os.fsencode(name)[:120].decode("utf-8", "ignore") + "~" + digest


def _temp_suffix(path: Path, suffix) -> str:
    suffix = suffix or "".join(path.suffixes) or ".tmp"
    return suffix if len(os.fsencode(suffix)) <= 24 else (path.suffix or ".tmp")[:24]


def remove_leftovers(path) -> list[Path]:
    """Remove temporary files that killed writers left beside `path`; return them."""
    path = Path(path)
    removed = []
    with contextlib.suppress(OSError):
        for entry in os.scandir(path.parent):
            m = _LEFTOVER.match(entry.name)
            if not m or m.group("name") != _temp_stem(path.name) or not entry.is_file(follow_symlinks=False):
                continue
            if not _pid_alive(int(m.group("pid"))):
                with contextlib.suppress(OSError):
                    os.unlink(entry.path)
                    removed.append(Path(entry.path))
    return removed


#: packages whose files ship with sparseedm: never an output (see check_paths)
_SHIPPED = ("sparseedm.dictionaries", "sparseedm.lifters")
#: longest file name most file systems take (bytes); temporaries add to the name
_NAME_MAX = 255


def _through_proc(path: Path) -> bool:
    """Whether `path` is a symlink whose chain passes through /proc (``/dev/stdout``)."""
    p = os.path.abspath(path)
    for _ in range(40):
        if not os.path.islink(p):
            return False
        p = os.path.normpath(os.path.join(os.path.dirname(p), os.readlink(p)))
        if p.startswith(("/proc/", "/dev/fd/")):
            return True
    return False


def _target(path: Path):
    """How to write `path`: ("replace", where) or ("stream", path).

    ``where`` is `path`, or the regular file a symlink at `path` points to.
    Raises OutputPathError for a directory, block device, socket or other
    special file: nothing sparseedm writes belongs there.
    """
    try:
        mode = os.stat(path).st_mode  # follows symlinks
    except (FileNotFoundError, NotADirectoryError):
        return "replace", path
    except OSError as exc:
        raise OutputPathError(f"{path}: cannot write it ({exc.strerror})") from None
    if stat.S_ISREG(mode):
        if not os.path.islink(path):
            return "replace", path
        if _through_proc(path):
            return "stream", path
        return "replace", Path(os.path.realpath(path))
    if stat.S_ISCHR(mode) or stat.S_ISFIFO(mode):
        return "stream", path
    if stat.S_ISDIR(mode):
        raise OutputPathError(f"{path} is a directory; give a file name")
    kind = ("a block device" if stat.S_ISBLK(mode) else "a socket" if stat.S_ISSOCK(mode)
            else "a special file")
    raise OutputPathError(f"{path} is {kind}, not a regular file: refusing to write over it")


def is_stream(path) -> bool:
    """Whether `path` is a device or pipe an output is written through (never replaced).

    Examples
    --------
    >>> is_stream("/dev/null"), is_stream("out.csv")
    (True, False)
    """
    try:
        return _target(Path(path))[0] == "stream"
    except OutputPathError:
        return False


def _shipped_dirs() -> list[Path]:
    from importlib import resources

    dirs = []
    for package in _SHIPPED:
        with contextlib.suppress(ModuleNotFoundError, TypeError, OSError):
            dirs.append(Path(str(resources.files(package))).resolve())
    return dirs


def _shipped(path: Path) -> bool:
    try:
        real = Path(os.path.realpath(path))
    except (OSError, ValueError):
        return False
    return any(real.parent == d or d in real.parents for d in _shipped_dirs())


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
        try:
            kind, _ = _target(out)
        except OutputPathError as exc:
            raise OutputPathError(f"{label} {exc}") from None
        if kind == "replace" and _shipped(out):
            raise OutputPathError(
                f"{label} {out} is inside the files shipped with sparseedm: refusing to "
                "write there; give a path outside the installed package")
        if len(os.fsencode(out.name)) > _NAME_MAX:
            raise OutputPathError(
                f"{label} {out}: the file name is {len(os.fsencode(out.name))} bytes; "
                f"file systems take at most {_NAME_MAX}")
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
    kind, path = _target(path)
    if kind == "stream":
        with _streamed(path, suffix) as tmp:
            yield tmp
        return
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OutputPathError(f"{path}: cannot create its folder ({exc.strerror})") from None
    remove_leftovers(path)
    try:
        fd, tmp = tempfile.mkstemp(
            prefix=f".{_temp_stem(path.name)}{TEMP_MARK}{os.getpid()}-",
            suffix=_temp_suffix(path, suffix), dir=path.parent,
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


@contextlib.contextmanager
def _streamed(path: Path, suffix):
    """A temporary in the system's temporary folder, streamed into `path` on success."""
    fd, tmp = tempfile.mkstemp(prefix=f"sparseedm-{os.getpid()}-",
                               suffix=_temp_suffix(path, suffix))
    os.close(fd)
    with _lock:
        if not _live:
            _install()
        _live.add(tmp)
    try:
        yield tmp
        with open(tmp, "rb") as src, open(path, "wb") as dst:  # a FIFO waits for its reader
            shutil.copyfileobj(src, dst, 1 << 20)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        with _lock:
            _live.discard(tmp)
            if not _live:
                _restore()


def save_npz(path, arrays, *, compressed=False):
    """Write `arrays` as an ``.npz`` at exactly `path` (whatever its extension), atomically.

    Never a pickle: an object array (e.g. frame numbers read as text, some
    blank) is written as strings, which ``np.load(allow_pickle=False)`` reads.
    """
    import numpy as np

    arrays = {k: (np.asarray(v).astype(str) if np.asarray(v).dtype == object else v)
              for k, v in arrays.items()}
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
