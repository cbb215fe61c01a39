"""Atomic file writes: a crash, Ctrl-C or SIGTERM never leaves a half-written output.

:func:`atomic_path` yields a temporary path beside the target and renames it
over the target on success. Temporary files are named
``.<name>.sparseedm-tmp-<pid>-<random><suffix>``: while one exists, SIGTERM,
SIGHUP and SIGINT (when Python's own Ctrl-C handler is not installed) remove it
before the previous handler runs, and a later write to the same target removes
the leftovers of writers that were killed outright (SIGKILL, power loss): the
``<pid>`` in the name is no longer running. The signal handlers are installed
before a temporary exists, and an output gets one temporary, however many
writers it passes through.

:func:`check_paths` refuses an output that is an input, another output, a
directory, or under a parent that is a regular file, before any work is done.

Only regular files are ever replaced. A target that exists and is a character
device or a named pipe (``/dev/null``, ``/dev/stdout``, a FIFO a reader waits
on), or a symlink to one, is written *through*: the finished temporary (made
in the system's temporary folder) is streamed into it, and the device or pipe
stays what it was. A symlink to a regular file is kept: its target is
replaced atomically (a symlink to nothing yet: its target is made). A block device or a socket is refused with an
:class:`~sparseedm.exceptions.OutputPathError`, and :func:`check_paths`
refuses any output inside the files shipped with the package.
"""

from __future__ import annotations

import contextlib
import ctypes
import json
import math
import os
import re
import shutil
import signal
import stat
import tempfile
import threading
from pathlib import Path

from .exceptions import OutputPathError

__all__ = ["atomic_path", "atomic_folder", "check_paths", "check_folder", "is_stream",
           "save_npz", "save_npy", "save_json", "json_text", "strict_json", "remove_leftovers",
           "fit_name", "TEMP_MARK", "FOLDER_MARK"]

#: every temporary file's name holds this (see the module docstring)
TEMP_MARK = ".sparseedm-tmp-"
#: the file in every folder output saying what sparseedm wrote there (JSON)
FOLDER_MARK = ".sparseedm-output"
_MARK_MAX_BYTES = 64 << 20
_PID = re.compile(r"(\d+)-")
_SIGNALS = tuple(getattr(signal, s) for s in ("SIGTERM", "SIGHUP", "SIGINT")
                 if hasattr(signal, s))

_live: set[str] = set()        # temporary files (and folders) of writes in progress
_pending: set = set()          # (folder, name prefix) of temporaries being made
_previous: dict = {}           # signal -> handler before ours
_lock = threading.Lock()


def _remove(tmp):
    """Remove a temporary file, or a temporary folder with what it holds."""
    if os.path.isdir(tmp) and not os.path.islink(tmp):
        shutil.rmtree(tmp, ignore_errors=True)
        return
    with contextlib.suppress(OSError):
        os.unlink(tmp)


def _remove_live():
    for tmp in list(_live):
        _remove(tmp)
        _live.discard(tmp)
    for pending in list(_pending):  # a temporary being made when the signal came
        _remove_announced(pending)


def _new_temp(make, folder, prefix):
    """`make()`'s new temporary (named `prefix`... in `folder`), removed on
    SIGTERM/SIGHUP/SIGINT until :func:`_release`: the handlers that remove it
    are installed, and the name it will have announced, before it exists, so
    a signal at any moment (whichever thread receives it) finds it."""
    pending = (os.fspath(folder), prefix)
    with _lock:
        if not _live and not _pending:
            _install()
        _pending.add(pending)
    tmp = None
    try:
        tmp = make()
    except OSError:
        raise
    except BaseException:  # Ctrl-C as it was made: the file may exist, unnamed here
        _remove_announced(pending)
        raise
    finally:
        with _lock:
            if tmp is not None:
                _live.add(tmp)
            _pending.discard(pending)
            if not _live and not _pending:
                _restore()
    return tmp


def _remove_announced(pending):
    """Remove the files of a temporary being made: (folder, name prefix)."""
    folder, prefix = pending
    with contextlib.suppress(OSError):
        for entry in os.scandir(folder):
            if entry.name.startswith(prefix):
                _remove(entry.path)


def _live_temp(path) -> bool:
    """Whether `path` is itself the temporary of a write in progress here (a
    writer handed a temporary writes into it: one temporary per output)."""
    where = os.path.abspath(path)
    with _lock:
        return any(os.path.abspath(t) == where for t in _live)


def _release(tmp):
    with _lock:
        _live.discard(tmp)
        if not _live and not _pending:
            _restore()


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


def fit_name(stem: str, ending: str = "", limit: int | None = None) -> str:
    """``stem + ending``, or, when that is over `limit` bytes (default the 255
    most file systems take), the stem's first 120 bytes, ``~`` and a hash of the
    whole stem, then `ending`: a name that fits, the same for the same stem.

    >>> fit_name("out", ".errors.csv")
    'out.errors.csv'
    >>> len(fit_name("p" * 249, ".errors.csv").encode())
    144
    """
    limit = _NAME_MAX if limit is None else limit
    if len(os.fsencode(stem + ending)) <= limit:
        return stem + ending
    import hashlib

    digest = hashlib.sha256(os.fsencode(stem)).hexdigest()[:12]
    return os.fsencode(stem)[:120].decode("utf-8", "ignore") + "~" + digest + ending


def _temp_stem(name: str) -> str:
    """`name` as it appears in its temporaries' names: shortened (with a hash of the
    whole) when the temporary's name would pass the file systems' limit."""
    return fit_name(name, limit=_NAME_MAX - 64)


def _temp_suffix(path: Path, suffix) -> str:
    suffix = suffix or "".join(path.suffixes) or ".tmp"
    return suffix if len(os.fsencode(suffix)) <= 24 else (path.suffix or ".tmp")[:24]


def remove_leftovers(path) -> list[Path]:
    """Remove temporary files (and a folder output's temporary folders) that killed
    writers left beside `path`; return them."""
    path = Path(path)
    removed = []
    with contextlib.suppress(OSError):
        for entry in os.scandir(path.parent):
            pid = _leftover_pid(entry.name, _temp_stem(path.name))
            if pid is None or not (entry.is_file(follow_symlinks=False)
                                   or entry.is_dir(follow_symlinks=False)):
                continue
            if not _pid_alive(pid):
                _remove(entry.path)
                if not os.path.lexists(entry.path):
                    removed.append(Path(entry.path))
    return removed


def _leftover_pid(name, stem):
    """The writer's pid in `name` if it is a temporary of the output named `stem`
    (``.<stem>.sparseedm-tmp-<pid>-...``, the one temporary-name prefix), or
    a temporary made inside such a temporary (``..<stem>.sparseedm-tmp-<pid>-...``
    with a second mark); else None.

    >>> _leftover_pid(".o.csv.sparseedm-tmp-12-ab.csv", "o.csv")
    12
    >>> _leftover_pid("..o.csv.sparseedm-tmp-12-ab.csv.sparseedm-tmp-12-cd.csv", "o.csv")
    12
    >>> _leftover_pid("..o.csv.sparseedm-tmp-12-ab.csv", "o.csv") is None  # .o.csv's
    True
    """
    for prefix, nested in ((f".{stem}{TEMP_MARK}", False), (f"..{stem}{TEMP_MARK}", True)):
        if name.startswith(prefix):
            rest = name[len(prefix):]
            m = _PID.match(rest)
            if m and (not nested or TEMP_MARK in rest):
                return int(m.group(1))
    return None


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
        # a dangling symlink is kept: the file is made where it points
        return "replace", Path(os.path.realpath(path)) if os.path.islink(path) else path
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


def _parent_ok(path: Path, writable=False):
    """Refuse `path` under a regular file and, if `writable`, in a folder (or below
    the nearest existing one, where its folder would be made) it cannot write."""
    for parent in (path.parent, *path.parent.parents):
        if parent.exists():
            if not parent.is_dir():
                raise OutputPathError(
                    f"{path}: cannot create it: {parent} is a file, not a directory")
            if writable and not os.access(parent, os.W_OK | os.X_OK):
                raise OutputPathError(
                    f"{path}: cannot write it: the folder {parent} is not writable "
                    "(permissions, a read-only or immutable folder)")
            return


def _umask() -> int:
    """The process's umask (read by setting it back)."""
    umask = os.umask(0)
    os.umask(umask)
    return umask


def check_paths(inputs=(), outputs=()):
    """Refuse outputs that would overwrite an input or each other, before any work.

    Paths are compared resolved (``..``, symlinks) and, when both exist, with
    :func:`os.path.samefile` (hard links). An output that is a directory, or
    whose parent is a regular file, is refused too, and so is one whose folder
    (or nearest existing folder above it) cannot be written.

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
            kind, where = _target(out)
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
        try:  # a device or pipe is written through: its folder need not be writable
            _parent_ok(out)
            _parent_ok(where, writable=kind == "replace")
        except OutputPathError as exc:
            raise OutputPathError(f"{label} {exc}") from None


def _temp_prefix(path: Path) -> str:
    """The start of every temporary's name beside `path` (what :func:`_leftover_pid`
    and :func:`remove_leftovers` recognise)."""
    return f".{_temp_stem(path.name)}{TEMP_MARK}{os.getpid()}-"


def _marked(path: Path):
    """The names a folder's :data:`FOLDER_MARK` lists (what sparseedm wrote there),
    or None without a readable mark."""
    mark = path / FOLDER_MARK
    try:
        if not mark.is_file() or mark.stat().st_size > _MARK_MAX_BYTES:
            return None
        doc = json.loads(mark.read_text(encoding="utf-8"))
    except (OSError, ValueError, RecursionError):  # RecursionError: a deeply nested mark
        return None
    files = doc.get("files") if isinstance(doc, dict) else None
    if not isinstance(files, list) or not all(isinstance(f, str) for f in files):
        return None
    return set(files)


def check_folder(path, label="output"):
    """Refuse a folder output that would replace a folder sparseedm did not write.

    A folder output (e.g. OpenPose frame files) may take the place of nothing,
    of an empty folder, or of a folder holding the :data:`FOLDER_MARK` file
    that sparseedm writes into each of its folder outputs and no file but the
    ones that mark lists. Anything else (a folder of the user's files, another
    clip's frames, an earlier output the user added to) is refused, as is a
    folder that cannot be written. Call it before the work; :func:`atomic_folder`
    calls it again.

    Raises
    ------
    OutputPathError

    Examples
    --------
    >>> import tempfile
    >>> d = Path(tempfile.mkdtemp())
    >>> _ = (d / "config.json").write_text("{}")
    >>> check_folder(d)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.OutputPathError: output ... did not write (it holds config.json): ...
    """
    given, path = path, Path(os.path.realpath(path))
    if os.path.lexists(path) and not path.is_dir():
        raise OutputPathError(f"{label} {given} is a file; a folder output needs a folder")
    _parent_ok(path, writable=True)
    if not path.is_dir():
        return
    if not os.access(path, os.W_OK | os.X_OK):
        raise OutputPathError(f"{label} {given}: the folder is not writable")
    written = _marked(path) or set()
    with os.scandir(path) as it:
        strangers = sorted(e.name for e in it if e.name != FOLDER_MARK and (
            e.name not in written or not e.is_file(follow_symlinks=False)))
    if strangers:
        named = ", ".join(strangers[:3]) + (", ..." if len(strangers) > 3 else "")
        why = "holds files sparseedm did not write" if written else \
            "is a folder sparseedm did not write"
        raise OutputPathError(f"{label} {given} {why} (it holds {named}): refusing to "
                              "replace it; give a new or empty folder")


_AT_FDCWD, _RENAME_EXCHANGE = -100, 2


def _exchange(a, b) -> bool:
    """Swap two paths in one step (Linux renameat2); False where it cannot."""
    try:
        renameat2 = ctypes.CDLL(None, use_errno=True).renameat2
    except (OSError, AttributeError, TypeError):
        return False
    renameat2.argtypes = [ctypes.c_int, ctypes.c_char_p, ctypes.c_int, ctypes.c_char_p,
                          ctypes.c_uint]
    return renameat2(_AT_FDCWD, os.fsencode(a), _AT_FDCWD, os.fsencode(b),
                     _RENAME_EXCHANGE) == 0


def _swap_in(tmp, path: Path):
    """`tmp` renamed to `path`; an earlier folder at `path` ends up at `tmp` (in one
    step where the system can) or is removed."""
    if not os.path.lexists(path):
        os.replace(tmp, path)
    elif not _exchange(tmp, path):
        old = tempfile.mkdtemp(prefix=_temp_prefix(path),
                               dir=path.parent)
        os.rmdir(old)
        os.replace(path, old)
        os.replace(tmp, path)
        _remove(old)


@contextlib.contextmanager
def atomic_folder(path, label="output"):
    """Yield a new temporary folder beside `path`; it takes `path`'s place on success.

    The folder output's counterpart of :func:`atomic_path`: :func:`check_folder`
    first (an existing folder is replaced only if sparseedm wrote it), the
    temporary folder named like a temporary file (removed on an exception,
    SIGTERM, SIGHUP; a killed writer's is removed by the next write to
    `path`), made with the umask's usual mode, and the :data:`FOLDER_MARK`
    file listing what it holds written into it last.

    Examples
    --------
    >>> import tempfile
    >>> out = Path(tempfile.mkdtemp()) / "frames"
    >>> for _ in range(2):  # the second write replaces the first
    ...     with atomic_folder(out) as tmp:
    ...         _ = (tmp / "0.json").write_text("{}")
    >>> sorted(os.listdir(out))
    ['.sparseedm-output', '0.json']
    """
    check_folder(path, label)
    path = Path(os.path.realpath(path))
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        remove_leftovers(path)
        tmp = _new_temp(lambda: tempfile.mkdtemp(prefix=_temp_prefix(path), dir=path.parent),
                        path.parent, _temp_prefix(path))
    except OSError as exc:
        raise OutputPathError(f"{path}: cannot write beside it ({exc.strerror})") from None
    try:
        os.chmod(tmp, 0o777 & ~_umask())  # mkdtemp makes 0700: give the usual mode
        yield Path(tmp)
        names = sorted(os.listdir(tmp))
        with open(os.path.join(tmp, FOLDER_MARK), "w", encoding="utf-8") as f:
            json.dump({"written_by": "sparseedm", "files": names}, f)
        _swap_in(tmp, path)
    finally:
        _remove(tmp)  # after the swap: the earlier output, if any
        _release(tmp)


@contextlib.contextmanager
def atomic_path(path, suffix=None):
    """Yield a temporary path beside `path`; rename it over `path` on success.

    The temporary file keeps `path`'s suffix (or `suffix`). On any exception,
    and on SIGTERM/SIGHUP, the temporary file is removed and `path` is
    untouched. Leftovers of killed earlier writers to `path` are removed first.
    The handlers that remove the temporary are in place before it exists. A
    `path` that is itself the temporary of a write in progress (a writer
    called on another's temporary, as ``recover_file`` calls
    ``write_keypoints``) is written directly: one temporary per output.
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
    if _live_temp(path):  # a writer below another's atomic write: no second temporary
        yield str(path)
        return
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
        tmp = _new_temp(lambda: _made_file(prefix=_temp_prefix(path),
                                           suffix=_temp_suffix(path, suffix), dir=path.parent),
                        path.parent, _temp_prefix(path))
    except OSError as exc:
        raise OutputPathError(f"{path}: cannot write beside it ({exc.strerror})") from None
    try:
        os.chmod(tmp, 0o666 & ~_umask())  # mkstemp makes 0600: give the usual mode
        yield tmp
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        raise
    finally:
        _release(tmp)


def _made_file(**where):
    """A new empty file by :func:`tempfile.mkstemp` (closed); its path."""
    fd, tmp = tempfile.mkstemp(**where)
    os.close(fd)
    return tmp


@contextlib.contextmanager
def _streamed(path: Path, suffix):
    """A temporary in the system's temporary folder, streamed into `path` on success."""
    prefix = f"sparseedm-{os.getpid()}-"
    tmp = _new_temp(lambda: _made_file(prefix=prefix, suffix=_temp_suffix(path, suffix)),
                    tempfile.gettempdir(), prefix)
    try:
        yield tmp
        with open(tmp, "rb") as src, open(path, "wb") as dst:  # a FIFO waits for its reader
            shutil.copyfileobj(src, dst, 1 << 20)
    finally:
        with contextlib.suppress(FileNotFoundError):
            os.unlink(tmp)
        _release(tmp)


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


def strict_json(obj, default=None):
    """`obj` as strict JSON holds it: NaN and infinities as None (``null``).

    Bare ``NaN`` / ``Infinity`` are not JSON: strict readers (JavaScript's
    ``JSON.parse``, ``jq``) refuse them. Numpy scalars and arrays become
    Python numbers and lists, tuples lists; `default` (as ``json.dumps``'s)
    turns any other object into something JSON holds, itself made strict.

    >>> strict_json({"a": float("nan"), "b": [1.5, float("-inf")], "c": (2, None)})
    {'a': None, 'b': [1.5, None], 'c': [2, None]}
    """
    if isinstance(obj, float):
        return float(obj) if math.isfinite(obj) else None
    if obj is None or isinstance(obj, (str, int)):
        return obj
    if isinstance(obj, dict):
        return {k: strict_json(v, default) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [strict_json(v, default) for v in obj]
    if callable(getattr(obj, "tolist", None)):  # numpy scalars and arrays
        return strict_json(obj.tolist(), default)
    return obj if default is None else strict_json(default(obj), default)


def json_text(obj, *, default=None, **kwargs):
    """`obj` as strict JSON text (:func:`strict_json`; ``allow_nan=False``
    refuses whatever would still not be JSON); `kwargs` go to ``json.dumps``.

    >>> json_text({"edge_jump": float("nan"), "n": 3})
    '{"edge_jump": null, "n": 3}'
    """
    return json.dumps(strict_json(obj, default), allow_nan=False, **kwargs)


def save_json(path, obj, **kwargs):
    """Write `obj` as strict JSON (:func:`json_text`) at exactly `path`, atomically."""
    text = json_text(obj, **kwargs)
    with atomic_path(path) as tmp:
        with open(tmp, "w", encoding="utf-8") as f:
            f.write(text)
    return Path(path)


def save_npy(path, array):
    """Write one array as ``.npy`` at exactly `path`, atomically."""
    import numpy as np

    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            np.save(f, array)
    return Path(path)
