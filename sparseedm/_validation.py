"""Argument validation in one place, in the spirit of scikit-learn's ``_param_validation``.

Every public function states the constraints of its arguments once, as a dict
``name -> list of constraints`` (an argument is valid when it satisfies ANY of
them), and calls :func:`validate_params`; a violation raises
:class:`~sparseedm.exceptions.ParameterError` (a ``SparseEDMError`` and a
``TypeError``) naming the function, the argument, what it must be and what it
got. Constraints:

``Interval(Real | Integral, left, right, closed=...)``
    a number (never a bool, a string or a complex) in a range; NaN never fits;
``Options(values)``
    one of a few values (compared with ``==`` on hashable values only);
``None``
    the value None;
``"boolean"``
    a Python or NumPy bool;
``"path"``
    a str or an ``os.PathLike``;
``type objects``
    ``isinstance`` (e.g. ``Dictionary`` or ``BaseSolver``).

Arrays have their own checks: :func:`check_poses` (a numeric, real,
rectangular (n, N, 2) array: ragged lists, strings, booleans, complex or
object arrays are refused) and :func:`check_mask` (booleans, or integers 0/1).

Examples
--------
>>> from numbers import Real
>>> validate_params("f", {"alpha": 0.5}, {"alpha": [Interval(Real, 0, None, closed="neither")]})
>>> validate_params("f", {"alpha": "0.5"}, {"alpha": [Interval(Real, 0, None, closed="neither")]})
Traceback (most recent call last):
...
sparseedm.exceptions.ParameterError: f: alpha must be a real number in (0, inf), got '0.5' (str)
"""

from __future__ import annotations

import datetime
import os
import re
from numbers import Integral, Real

import numpy as np

from .exceptions import ParameterError, PoseError

__all__ = ["Interval", "Options", "validate_params", "check_poses", "check_pose_shape",
           "check_mask", "ALPHA", "ALPHA_MIN", "ALPHA_MAX", "ENSEMBLE", "MAX_ENSEMBLE", "N_JOBS",
           "CHUNK_SIZE", "PATH", "BOOLEAN", "THRESHOLD", "SCORE", "usable_jobs",
           "unmask", "environment_problem", "MAX_FRAME", "NUMBER_TEXT", "frame_value", "frame_array",
           "frame_numbers", "read_frames", "check_frames", "check_adapt"]


class Interval:
    """Numbers of one kind (``Real`` or ``Integral``) between `left` and `right`.

    `closed` is ``"both"``, ``"left"``, ``"right"`` or ``"neither"``; a bound of
    None is unbounded. Booleans are never numbers here, and a Real interval
    refuses NaN and (unless a bound is None and closed there) infinities.
    """

    def __init__(self, kind, left, right, *, closed="both"):
        self.kind, self.left, self.right, self.closed = kind, left, right, closed

    def is_satisfied_by(self, value) -> bool:
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, self.kind):
            return False
        if isinstance(value, Real) and not np.isfinite(float(value)):
            return False
        left_ok = self.left is None or (
            value >= self.left if self.closed in ("both", "left") else value > self.left)
        right_ok = self.right is None or (
            value <= self.right if self.closed in ("both", "right") else value < self.right)
        return bool(left_ok and right_ok)

    def __str__(self):
        what = "an integer" if self.kind is Integral else "a real number"
        lo = "-inf" if self.left is None else self.left
        hi = "inf" if self.right is None else self.right
        lb = "[" if self.closed in ("both", "left") and self.left is not None else "("
        rb = "]" if self.closed in ("both", "right") and self.right is not None else ")"
        return f"{what} in {lb}{lo}, {hi}{rb}"


class Options:
    """One of a fixed set of (hashable) values."""

    def __init__(self, values):
        self.values = tuple(values)

    def is_satisfied_by(self, value) -> bool:
        try:
            hash(value)
        except TypeError:
            return False
        return any(type(value) is type(v) and value == v for v in self.values)

    def __str__(self):
        return "one of " + ", ".join(repr(v) for v in self.values)


def _satisfied(constraint, value) -> bool:
    if constraint is None:
        return value is None
    if constraint == "boolean":
        return isinstance(value, (bool, np.bool_))
    if constraint == "path":
        return isinstance(value, (str, os.PathLike)) and str(value) != ""
    if isinstance(constraint, type):
        return isinstance(value, constraint)
    return constraint.is_satisfied_by(value)


def _describe(constraint) -> str:
    if constraint is None:
        return "None"
    if constraint == "boolean":
        return "a bool"
    if constraint == "path":
        return "a non-empty path (str or os.PathLike)"
    if isinstance(constraint, type):
        return f"a {constraint.__name__}"
    return str(constraint)


def _show(value) -> str:
    text = repr(value)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{text} ({type(value).__name__})"


def validate_params(caller, params, constraints):
    """Check each ``params[name]`` against ``constraints[name]`` (any may fit).

    Raises
    ------
    ParameterError
        Naming `caller`, the argument, what it must be and what it got.
    """
    for name, value in params.items():
        allowed = constraints[name]
        if any(_satisfied(c, value) for c in allowed):
            continue
        options = [_describe(c) for c in allowed]
        must = options[0] if len(options) == 1 else ", ".join(options[:-1]) + " or " + options[-1]
        raise ParameterError(f"{caller}: {name} must be {must}, got {_show(value)}")


#: the lasso penalties the solvers are meaningful for, on vectors of poses normalised
#: to [-1, 1] (norm at most ~76 for 14 joints): above ALPHA_MAX every code is zero,
#: below ALPHA_MIN the duality gap cannot be certified (and LARS takes minutes)
ALPHA_MIN, ALPHA_MAX = 1e-6, 100.0
#: constraints shared by several functions
ALPHA = [Interval(Real, ALPHA_MIN, ALPHA_MAX)]
#: most members an ensemble takes: each is a whole adapted dictionary in memory
MAX_ENSEMBLE = 64
ENSEMBLE = [Interval(Integral, 1, MAX_ENSEMBLE)]
N_JOBS = [Interval(Integral, None, -1), Interval(Integral, 1, None), None]
CHUNK_SIZE = [Interval(Integral, 1, None)]
PATH = ["path"]
BOOLEAN = ["boolean"]
THRESHOLD = [Interval(Real, None, None)]
#: a confidence score a file gets (e.g. a filled joint's): every format's reader takes it
SCORE = [Interval(Real, 0, 1)]


def usable_jobs(n_jobs, n_tasks=None) -> int:
    """`n_jobs` capped at what can run: this machine's CPUs and the tasks there are.

    ``None`` is 1; a negative count is joblib's (-1 all CPUs, -2 all but one...).
    A count past the CPUs only adds workers that wait (and joblib fails to start
    100,000 of them), so ``--jobs 100000`` runs as ``--jobs -1``.

    Examples
    --------
    >>> usable_jobs(10**20) == (os.cpu_count() or 1), usable_jobs(10**20, n_tasks=1)
    (True, 1)
    >>> usable_jobs(None), usable_jobs(-10**6)
    (1, 1)
    """
    if n_jobs is None:
        return 1
    cpus = os.cpu_count() or 1
    n = min(int(n_jobs), cpus) if n_jobs > 0 else max(cpus + 1 + int(n_jobs), 1)
    if n_tasks is not None:
        n = min(n, max(int(n_tasks), 1))
    return max(n, 1)


def check_poses(poses, caller, name="poses"):
    """`poses` as a float64 array, refusing anything that is not plain real numbers.

    Ragged nested lists, strings, booleans, complex numbers and object arrays
    raise :class:`ParameterError` naming `caller` and `name`; shapes are the
    caller's business.

    Examples
    --------
    >>> check_poses([[0, 1], [2, 3]], "f").dtype
    dtype('float64')
    >>> check_poses([[0, 1], [2]], "f")
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.ParameterError: f: poses must be a rectangular array of real numbers; got a ragged sequence (lengths differ)
    """
    try:
        arr = np.asarray(poses)
    except ValueError:
        raise ParameterError(
            f"{caller}: {name} must be a rectangular array of real numbers; got a "
            "ragged sequence (lengths differ)") from None
    except (TypeError, OverflowError) as exc:
        raise ParameterError(f"{caller}: {name} is not an array of numbers ({exc})") from None
    if arr.dtype.kind == "O":
        try:  # a list mixing floats and Python ints too big for int64, etc.
            arr = arr.astype(np.float64)
        except (TypeError, ValueError, OverflowError):
            raise ParameterError(
                f"{caller}: {name} must hold real numbers only; got objects "
                f"({', '.join(sorted({type(v).__name__ for v in arr.flat}))[:80]}) in "
                f"{_given(poses, arr)}") from None
    if arr.dtype.kind not in "fiu":
        kind = {"b": "booleans", "c": "complex numbers", "U": "strings", "S": "bytes",
                "M": "dates", "m": "time deltas", "V": "raw records"}.get(arr.dtype.kind,
                                                                          str(arr.dtype))
        raise ParameterError(f"{caller}: {name} must hold real numbers; got {kind} "
                             f"(dtype {arr.dtype})")
    with np.errstate(over="ignore"):
        return arr.astype(np.float64, copy=False)


def check_adapt(adapt, caller, n_joints):
    """recover()'s `adapt` checked once: ``"auto"``, False or None as given, or the
    poses to adapt on as a float array (n, `n_joints`, 2) (NaN rows are fine: only
    complete rows are used).

    Raises :class:`~sparseedm.exceptions.ParameterError` for another string, a
    boolean True, a number or an array of other than real numbers, and
    :class:`~sparseedm.exceptions.PoseError` for another shape.

    Examples
    --------
    >>> check_adapt("auto", "f", 14), check_adapt(False, "f", 14)
    ('auto', False)
    >>> check_adapt(np.zeros((5, 14, 2), int), "f", 14).dtype
    dtype('float64')
    >>> check_adapt(True, "f", 14)
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.ParameterError: f: adapt must be 'auto', False or an array of poses (n, 14, 2); got True (bool)
    """
    if adapt is None or adapt is False or (isinstance(adapt, str) and adapt == "auto"):
        return adapt
    if isinstance(adapt, (str, bytes, bool, np.bool_)) or np.isscalar(adapt):
        raise ParameterError(f"{caller}: adapt must be 'auto', False or an array of poses "
                             f"(n, {n_joints}, 2); got {_show(adapt)}")
    poses = check_poses(adapt, caller, "adapt")
    check_pose_shape(poses, "adapt poses", n_joints=n_joints, given=adapt)
    return poses


def unmask(poses, missing, caller):
    """A masked array's masked joints made missing (``np.ma``: mask = missing).

    A joint with any masked coordinate gets NaN coordinates and, when a
    `missing` mask is given, is added to it. Anything else comes back as given.

    Examples
    --------
    >>> p = np.ma.array([[[1.0, 2.0], [3.0, 4.0]]], mask=[[[False, False], [True, False]]])
    >>> poses, missing = unmask(p, None, "f")
    >>> poses.tolist(), missing
    ([[[1.0, 2.0], [nan, nan]]], None)
    """
    if not isinstance(poses, np.ma.MaskedArray):
        return poses, missing
    masked = np.ma.getmaskarray(poses)
    data = check_poses(np.ma.getdata(poses), caller)
    hidden = masked.any(axis=-1) if data.ndim >= 2 else masked
    data = np.where(hidden[..., None] if data.ndim >= 2 else hidden, np.nan, data)
    if missing is not None:
        mask = check_mask(missing, caller)
        if mask.shape == hidden.shape:
            missing = mask | hidden
    return data, missing


def _given(value, arr, dim=2, n_joints=None):
    """What the caller passed, for a message: its type and real shape, and for
    a table (a pandas DataFrame) how to pass its numbers as poses."""
    shape = getattr(value, "shape", None)
    shape = tuple(shape) if isinstance(shape, tuple) else arr.shape
    kind = type(value)
    module = kind.__module__.split(".")[0]
    name = kind.__name__ if module in ("builtins", "numpy") else f"{module} {kind.__name__}"
    text = f"{shape} ({name})"
    if kind.__name__ == "DataFrame":
        text += (f"; pass its numbers as .to_numpy().reshape(n, {n_joints or 'N'}, {dim}) "
                 "(x, y per joint, in sparseedm.skeleton.JOINT_NAMES order) or read the "
                 "file with sparseedm.read_keypoints")
    return text


def check_pose_shape(poses, name="poses", *, dim=2, n_joints=None, model="dictionary",
                     given=None):
    """Refuse an array that is not `dim`-D poses (n, N, dim), or not `n_joints`
    joints: the one shape rule of recovery, adaptation, evaluation, the baselines,
    the cameras and FConv training.

    Raises :class:`~sparseedm.exceptions.PoseError` naming `name` (and the
    `model` the joint count is for); with `given`, the object the caller
    passed (before it became `poses`), the message names its type and shape.

    Examples
    --------
    >>> check_pose_shape(np.zeros((3, 14, 2)), n_joints=14)
    >>> check_pose_shape(np.zeros((3, 14)), "test poses")
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.PoseError: test poses must have shape (n, N, 2), got (3, 14)
    """
    if poses.ndim != 3 or poses.shape[-1] != dim:
        got = poses.shape if given is None else _given(given, poses, dim, n_joints)
        raise PoseError(f"{name} must have shape (n, N, {dim}), got {got}")
    if n_joints is not None and poses.shape[1] != n_joints:
        raise PoseError(
            f"{name} have {poses.shape[1]} joints but the {model} is for {n_joints}"
        )


def check_mask(missing, caller, name="missing"):
    """A boolean mask from booleans or integers 0/1; anything else is refused.

    Examples
    --------
    >>> check_mask([[0, 1]], "f").tolist()
    [[False, True]]
    >>> check_mask([["yes", "no"]], "f")
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.ParameterError: f: missing must hold booleans (or 0/1); got strings (dtype <U3)
    """
    try:
        arr = np.asarray(missing)
    except ValueError:
        raise ParameterError(f"{caller}: {name} must be a rectangular boolean array; "
                             "got a ragged sequence") from None
    if arr.dtype.kind == "b":
        return arr
    if arr.dtype.kind in "iu" or (arr.dtype.kind == "f" and np.isfinite(arr).all()):
        if np.isin(arr, (0, 1)).all():
            return arr.astype(bool)
        raise ParameterError(f"{caller}: {name} must hold booleans (or 0/1); got other "
                             "numbers")
    kind = {"U": "strings", "S": "bytes", "O": "objects", "c": "complex numbers",
            "f": "NaN or infinite values"}.get(arr.dtype.kind, str(arr.dtype))
    raise ParameterError(f"{caller}: {name} must hold booleans (or 0/1); got {kind} "
                         f"(dtype {arr.dtype})")


# --------------------------------------------------------------------------
# frame numbers: the one rule every reader and the recovery across time use

#: the largest frame-number magnitude used across time: every integer up to it is
#: exact as a float, and differences of two of them never overflow int64
MAX_FRAME = 2**53
#: a plain decimal number (or nan/inf) in text: not Python's extras ("1_0",
#: full-width or other non-ASCII digits), which coordinates and frame numbers refuse
NUMBER_TEXT = re.compile(r"[+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?|[+-]?(?:nan|inf|infinity)",
                         re.IGNORECASE | re.ASCII)


def frame_value(v):
    """One frame number's int value and ``""``, or 0 and why it is refused.

    The one frame-number rule: a whole number of magnitude at most
    :data:`MAX_FRAME`, given as an integer, a float or text in
    :data:`NUMBER_TEXT`'s plain decimal form (never a bool, ``"1_0"`` or
    full-width digits); a larger one is refused as too large, never wrapped.

    Examples
    --------
    >>> frame_value(12), frame_value("12.0"), frame_value(2**64)[1]
    ((12, ''), (12, ''), 'frame number 18446744073709551616 is too large (over 2**53)')
    >>> frame_value("1_0")[1], frame_value("\uff11\uff12")[1]
    ("frame number '1_0' is not a number", "frame number '\uff11\uff12' is not a number")
    """
    if isinstance(v, (bool, np.bool_)):
        return 0, f"frame number {v!r} is a boolean, not a number"
    if isinstance(v, (int, np.integer)):
        return (int(v), "") if abs(int(v)) <= MAX_FRAME else \
            (0, f"frame number {v} is too large (over 2**53)")
    if isinstance(v, (str, bytes)):
        text = v.decode("ascii", "replace") if isinstance(v, bytes) else v
        if not NUMBER_TEXT.fullmatch(text.strip()):
            return 0, f"frame number {v!r} is not a number"
    try:
        f = float(v)
    except (TypeError, ValueError, OverflowError):
        return 0, f"frame number {v!r} is not a number"
    if np.isnan(f) or (np.isinf(f) and "inf" in str(v).lower()):
        return 0, f"frame number is {f}"
    if abs(f) > MAX_FRAME:  # "1e999" or 400 digits of text too
        return 0, f"frame number {v!r} is too large (over 2**53)"
    if f != round(f):
        return 0, f"frame number {v!r} is not an integer"
    return int(f), ""


def frame_numbers(frames, n):
    """Frames as int64 (n,) and the reason each unusable one is refused (`""` if usable).

    A frame number must be a whole number of magnitude at most :data:`MAX_FRAME`
    (whatever its dtype: a larger one is refused as too large, never wrapped):
    the one rule, :func:`frame_value`, row by row.

    Parameters
    ----------
    frames : array_like (n,)
        Frame numbers, one per pose, of any dtype.
    n : int
        The number of poses.

    Returns
    -------
    values : ndarray of int64 (n,)
        The frame numbers (0 where refused).
    reason : ndarray of str (n,)
        Why each refused frame number is unusable; ``""`` where usable.

    Raises
    ------
    ParameterError
        If `frames` does not have shape ``(n,)``.

    Examples
    --------
    >>> values, reason = frame_numbers(np.array([3, 2**63 + 5], dtype=np.uint64), 2)
    >>> values.tolist(), reason.tolist()
    ([3, 0], ['', 'frame number 9223372036854775813 is too large (over 2**53)'])
    """
    arr = np.asarray(frames)
    if arr.shape != (n,):
        raise ParameterError(f"frames must have shape ({n},) (one per pose), got {arr.shape}")
    values = np.zeros(n, dtype=np.int64)
    reason = np.full(n, "", dtype=object)
    rows = np.arange(n)
    if arr.dtype.kind in "iuf":  # the usual cases at once; only the others get a reason
        if arr.dtype.kind == "u":
            usable = arr <= MAX_FRAME
        elif arr.dtype.kind == "i":
            usable = (arr <= MAX_FRAME) & (arr >= -MAX_FRAME)
        else:  # floats (CSV columns): finite whole numbers
            f = arr.astype(float)
            usable = np.isfinite(f) & (np.abs(f) <= MAX_FRAME)
            usable[usable] = f[usable] == np.round(f[usable])
        values[usable] = arr[usable].astype(np.int64)
        rows = np.flatnonzero(~usable)
    for i, v in zip(rows, arr[rows].tolist()):
        values[i], reason[i] = frame_value(v)
    return values, reason


def read_frames(frames):
    """`frames` read once by the frame-number rule (:func:`frame_numbers`), for a
    caller whose later steps each read them again.

    Every frame number usable: their int64 values, which each later reading takes
    at numpy speed with the same result, instead of value by value (text, floats
    in an object array: a CSV column of ``"12.0"``). Some refused: `frames` as
    given (a refused one's reason names its own value).

    Examples
    --------
    >>> read_frames(np.array(["0.0", "1.0", "3"], dtype=object)).tolist()
    [0, 1, 3]
    >>> read_frames(np.array(["0.0", "1.5"], dtype=object)).dtype.name  # 1.5: refused
    'object'
    >>> read_frames(None) is None
    True
    """
    if frames is None:
        return None
    values, reason = frame_numbers(frames, len(np.asarray(frames)))
    return values if (reason == "").all() else frames


def frame_array(values):
    """Frame numbers as read (ints, or text) in one array: int64 when every one
    is an int that fits, else an object array whose odd values
    :func:`frame_value` refuses row by row (never an OverflowError).

    >>> frame_array([3, 4]).dtype.name, frame_array([3, 2**70]).dtype.name
    ('int64', 'object')
    """
    values = list(values)
    if all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_))
           and -2**63 <= int(v) < 2**63 for v in values):
        return np.asarray(values, dtype=np.int64)
    out = np.empty(len(values), dtype=object)
    out[:] = values
    return out


#: values that are no frame numbers whatever they convert to (a boolean, a date)
_NOT_FRAMES = {"b": "booleans", "M": "dates", "m": "time deltas"}


def check_frames(frames, caller, name="frames"):
    """Refuse frame numbers given as booleans or dates / times at an API entrance,
    as the readers refuse them (:func:`frame_value`); `frames` come back as given.

    Other odd values (too large, not whole) are the rows' business: their poses
    are recovered per frame with the reason, as a file's.

    Examples
    --------
    >>> check_frames([0, 1, 2], "f")
    [0, 1, 2]
    >>> check_frames(np.array([True, False]), "f")
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.ParameterError: f: frames must be frame numbers (whole numbers); got booleans (dtype bool)
    """
    try:
        arr = np.asarray(frames)
    except ValueError:
        return frames  # ragged: the shape rule names it
    kind = _NOT_FRAMES.get(arr.dtype.kind)
    if kind is None and (arr.dtype.kind == "O" or not isinstance(frames, np.ndarray)):
        # a list's True next to numbers becomes 1 in an array: look at the values given
        given = arr.flat if isinstance(frames, np.ndarray) or arr.ndim != 1 else frames
        odd = next((v for v in given if isinstance(v, (bool, np.bool_, datetime.date,
                    datetime.time, datetime.timedelta, np.datetime64, np.timedelta64))), None)
        if odd is not None:
            kind = f"{type(odd).__name__} {odd!r}"
    if kind is not None:
        raise ParameterError(f"{caller}: {name} must be frame numbers (whole numbers); got "
                             f"{kind} (dtype {arr.dtype})")
    return frames


def environment_problem():
    """What is wrong with an environment variable a dependency reads as it loads,
    or None: ``NUMBA_NUM_THREADS`` set to a whole number below 1 stops numba
    (the solvers') from importing at all. (A value numba cannot parse it
    ignores, with a warning, so that one is no problem.)

    Examples
    --------
    >>> os.environ.get("NUMBA_NUM_THREADS", "1") != "0" and environment_problem() is None
    True
    """
    value = os.environ.get("NUMBA_NUM_THREADS")
    try:
        threads = int(value)
    except (TypeError, ValueError):
        return None
    if threads >= 1:
        return None
    return (f"the environment variable NUMBA_NUM_THREADS={value!r} is not a thread count: "
            "numba, which sparseedm's solvers use, needs a whole number >= 1; unset it or "
            "set e.g. NUMBA_NUM_THREADS=2")
