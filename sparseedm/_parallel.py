"""Parallel plumbing shared by the recovery kernel, learning and the dictionary
lifter: chunks of rows for joblib, numba's thread count, the Dask client."""

from __future__ import annotations

from contextlib import contextmanager

import numba
import numpy as np
from joblib import effective_n_jobs

from .exceptions import ParameterError, SparseEDMError
from .solvers.fast import NUMPY_MAX

__all__ = ["chunk_tasks", "min_tasks", "TASK_MIN_ROWS", "dask_client", "one_client",
           "numba_threads", "worker_threads", "leaves_cores_idle", "PROCESS_BACKENDS"]


def chunk_tasks(rows, chunk_size, n_jobs, backend=None, shared=False, threads=None):
    """`rows` cut into consecutive tasks: at most `chunk_size` each, and enough
    of them to keep every worker busy (:func:`min_tasks`, `shared` and `threads`
    as there); none when `rows` is empty. Shared by recover() and the dictionary
    lifter."""
    n, chunk_size = len(rows), int(chunk_size)  # np.uint64(7): -n // it overflows
    n_tasks = max(-(-n // chunk_size), min_tasks(n_jobs, backend, n, shared, threads))
    return [t for t in np.array_split(rows, max(1, min(n_tasks, n))) if len(t)]


#: With `shared` (:func:`min_tasks`), the fewest rows a task gets: a worker takes at
#: least two such tasks (so joblib evens out their costs: rows sorted by missing
#: pattern differ in cost from one chunk to the next) or the work stays one task in
#: this process, where the fast solver's compiled kernel already shares the rows
#: among numba's threads as they free up. Cutting 199 poses into three tasks for
#: two workers had left one worker a third of the rows alone (``recover(n_jobs=2)``
#: slower than ``n_jobs=1`` on a 400-pose file).
TASK_MIN_ROWS = 128


def min_tasks(n_jobs, backend, n_rows, shared=False, threads=None):
    """Tasks enough to keep every worker busy (1 when the work runs in-process).

    Never so many that a task falls under the fast solver's compiled-kernel
    size (:data:`sparseedm.solvers.fast.NUMPY_MAX` rows): smaller batches take
    its numpy path, which is meant for a handful of poses and ran 2 jobs on
    300 poses at 42 poses/s against 600 for one job. With `shared` (one task in
    this process would already run on every core: the fast solver's kernels on
    numba's threads) each worker gets at least two tasks of at least
    :data:`TASK_MIN_ROWS` rows, at most four, or the rows stay one task; and
    they stay one task too when the workers, one numba thread each
    (:func:`worker_threads`), are fewer than numba's `threads` (default
    ``numba.get_num_threads()``): in-process they run on every core.

    Examples
    --------
    >>> min_tasks(2, None, 400), min_tasks(2, None, 400, shared=True, threads=2)
    (6, 1)
    >>> min_tasks(2, None, 6000, shared=True, threads=2), min_tasks(1, None, 6000)
    (8, 1)
    >>> min_tasks(2, None, 6000, shared=True, threads=4)  # 2 cores of 4 left idle
    1
    """
    if n_jobs in (None, 1) and backend is None:
        return 1
    workers = max(effective_n_jobs(n_jobs), 1)
    if not shared:
        return max(min(4 * workers, n_rows // NUMPY_MAX), 1)
    fit = n_rows // max(TASK_MIN_ROWS, NUMPY_MAX)
    if fit < 2 * workers or leaves_cores_idle(workers, threads):
        return 1
    return min(4 * workers, fit)


def leaves_cores_idle(n_workers, threads=None):
    """Whether `n_workers` thread workers of one numba thread each (:func:`worker_threads`)
    are fewer than numba's `threads` (default ``numba.get_num_threads()``, normally
    every core): the work then runs faster in this process on all of them.

    >>> leaves_cores_idle(2, 4), leaves_cores_idle(2, 2), leaves_cores_idle(4, 2)
    (True, False, False)
    """
    threads = numba.get_num_threads() if threads is None else int(threads)
    return int(n_workers) < threads


#: joblib backends whose workers are processes (each with its own numba threads)
PROCESS_BACKENDS = ("loky", "multiprocessing")


def worker_threads(n_workers, backend, threads=None):
    """numba threads for each of `n_workers` joblib workers on `backend`.

    Process workers share out numba's `threads` (default
    ``numba.get_num_threads()``, normally every core): ``cores // n_workers``
    each, at least one, so that two workers on four cores leave none idle.
    Thread workers (``"threading"``) and Dask's get one: numba's parallel
    regions launched from several threads of one process serialise (the
    OpenMP layer; its workqueue layer is not thread-safe), and a Dask worker
    is another machine's.

    Examples
    --------
    >>> [worker_threads(2, "loky", 4), worker_threads(3, "loky", 4), worker_threads(8, "loky", 4)]
    [2, 1, 1]
    >>> worker_threads(2, "threading", 4), worker_threads(2, "dask", 4)
    (1, 1)
    """
    if backend not in PROCESS_BACKENDS:
        return 1
    threads = numba.get_num_threads() if threads is None else int(threads)
    return max(1, threads // max(int(n_workers), 1))


#: the comms a scheduler in another process listens on (distributed's ``inproc://`` is
#: this process's own: no address a user gives, and connecting to one that does not
#: exist can wait without end once the process has run a cluster)
REMOTE_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx")


def _check_scheduler(address):
    """Refuse a scheduler address that is not ``scheme://host:port`` of a remote
    comm (or a bare ``host:port``, which distributed reads as tcp), before the client
    tries it."""
    text = str(address)
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    host, _, port = rest.rpartition(":")
    if scheme not in REMOTE_SCHEMES or not host or not port.isdigit():
        raise ParameterError(
            f"scheduler {address!r} is not an address the Dask client can connect to; "
            f"give a running scheduler's address, e.g. tcp://host:8786 (schemes: "
            f"{', '.join(REMOTE_SCHEMES)})")


class dask_client:
    """Connect to `scheduler` (closed afterwards), or use this process's client."""

    def __init__(self, scheduler):
        self.scheduler = scheduler
        self.client = None

    def __enter__(self):
        try:
            from distributed import Client, get_client
        except ImportError:
            raise SparseEDMError(
                "backend='dask' needs dask.distributed: pip install 'sparseedm[dask]'"
            ) from None
        if self.scheduler:
            _check_scheduler(self.scheduler)
            try:
                self.client = Client(self.scheduler, timeout="10s")
            except OSError as exc:
                raise SparseEDMError(
                    f"cannot reach the Dask scheduler at {self.scheduler}: {exc}"
                ) from None
            except (ValueError, TypeError) as exc:  # distributed's address parsing
                raise ParameterError(
                    f"scheduler {self.scheduler!r} is not an address the Dask client can "
                    f"connect to ({exc}); give a running scheduler's address, e.g. "
                    "tcp://host:8786"
                ) from None
        else:
            try:
                get_client()
            except ValueError:
                raise SparseEDMError(
                    "backend='dask' needs a scheduler address or a Client created "
                    "in this process"
                ) from None
        return self

    def __exit__(self, *exc):
        if self.client is not None:
            self.client.close()


@contextmanager
def one_client(backend, scheduler):
    """``backend="dask"``: one Dask client (:class:`dask_client`) held for a whole call,
    and the settings its inner steps take to use it (``backend="dask"``, scheduler None:
    this client); any other backend: no client and no settings (the adaptation's
    recoveries stay in this process)."""
    if backend != "dask":
        yield {}
        return
    with dask_client(scheduler):
        yield dict(backend="dask", scheduler=None)


class numba_threads:
    """numba's thread count set from `n_jobs` (-1: all), restored on exit."""

    def __init__(self, n_jobs):
        self.n_jobs = n_jobs

    def __enter__(self):
        self.old = numba.get_num_threads()
        if self.n_jobs is not None:
            n = numba.config.NUMBA_NUM_THREADS
            want = n if self.n_jobs < 0 else min(int(self.n_jobs), n)
            numba.set_num_threads(max(want, 1))

    def __exit__(self, *exc):
        numba.set_num_threads(self.old)
