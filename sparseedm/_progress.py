"""What a long step is doing, told to the person waiting for it.

The library is silent by default (a library does not write to stderr
uninvited); the command line turns this on with :func:`enable` unless
``--quiet``. Then every stage that can take more than a couple of seconds says
so as it starts: on a terminal as a tqdm bar where the stage has countable
steps, otherwise as one line per stage on stderr, e.g.::

    sparseedm: adapting the dictionary on 1,200 complete poses (seed 0)

Library code calls :func:`say` (one line: a stage, or a fact such as an
ensemble member dropped and why), :func:`once` (a line the first time only,
e.g. a JIT compilation) and :func:`steps` (an iterable: a bar on a terminal).

>>> from sparseedm import _progress
>>> _progress.say("not shown: progress is off")
>>> list(_progress.steps(range(3), "counting"))
[0, 1, 2]
"""

from __future__ import annotations

import contextlib
import sys
import threading

__all__ = ["enable", "enabled", "say", "steps", "once", "turned_on"]

_state = {"on": False, "tty": False, "stream": None}
_seen = set()
_lock = threading.Lock()


def enable(on=True, stream=None):
    """Turn progress reporting on (or off) for this process; `stream` defaults to stderr."""
    stream = sys.stderr if stream is None else stream
    _state.update(on=bool(on), stream=stream,
                  tty=bool(on) and bool(getattr(stream, "isatty", lambda: False)()))


def enabled() -> bool:
    return _state["on"]


@contextlib.contextmanager
def turned_on(on):
    """Reporting on for the block when `on` (an API call's ``progress=True``),
    then as it was; off stays as the caller set it.

    >>> with turned_on(True):
    ...     enabled()
    True
    >>> enabled()
    False
    """
    if not on or _state["on"]:
        yield
        return
    saved = dict(_state)
    enable(True)
    try:
        yield
    finally:
        _state.update(saved)


def _write(text):
    from tqdm.auto import tqdm

    # through tqdm.write so that a bar on screen is redrawn below the line
    tqdm.write(f"sparseedm: {text}", file=_state["stream"])


def say(text):
    """One line on stderr saying what starts now (nothing unless enabled)."""
    if _state["on"]:
        _write(text)


def once(key, text):
    """:func:`say` `text` the first time `key` is seen in this process (e.g. a JIT compile)."""
    with _lock:
        if key in _seen:
            return
        _seen.add(key)
    say(text)


def steps(iterable, what, total=None, unit="step"):
    """`iterable`, told as a stage: a tqdm bar on a terminal, else one line on stderr."""
    if not _state["on"]:
        return iterable
    if not _state["tty"]:
        _write(what)
        return iterable
    from tqdm.auto import tqdm

    return tqdm(iterable, desc=what, total=total, unit=unit, file=_state["stream"],
                dynamic_ncols=True, leave=False)


def jit(kernel, what):
    """Say, once per process, that numba `kernel` is about to be compiled or loaded.

    Its first call in a process compiles it (tens of seconds, the first time on a
    machine) or loads it from numba's on-disk cache (about a second); either way
    a long first step is then explained. `kernel` is a numba dispatcher.
    """
    if _state["on"] and not getattr(kernel, "signatures", True):
        once(("jit", what), f"preparing the numba kernels for {what} (compiled on a "
             "machine's first run, up to a minute, then loaded from numba's cache)")
