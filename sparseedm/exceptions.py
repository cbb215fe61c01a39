"""Errors and warnings sparseedm raises.

All errors derive from :class:`ValueError` so that callers that already catch
bad-input errors keep working; each message names the file, row or array and
what is wrong with it.
"""

__all__ = [
    "SparseEDMError",
    "PoseError",
    "FileFormatError",
    "PickledDataError",
    "DictionaryError",
    "ParameterError",
    "OutputPathError",
    "ModelError",
    "EnvironmentSettingError",
    "ConvergenceWarning",
]


class SparseEDMError(ValueError):
    """Base class of every error sparseedm raises on bad input."""


class PoseError(SparseEDMError):
    """Pose arrays of the wrong shape, with NaN/inf, or too few joints."""


class FileFormatError(SparseEDMError):
    """A malformed, truncated or unsupported input file.

    The message names the file and, where known, the line or row.
    """


class PickledDataError(FileFormatError):
    """A file (or an array in one) that holds a Python pickle: refused, never loaded."""


class DictionaryError(SparseEDMError):
    """A dictionary file that is corrupt, unsafe, or does not fit the data."""


class ParameterError(SparseEDMError, TypeError):
    """An argument of a public function or a CLI option of the wrong type or
    out of range; the message names the argument (see
    :mod:`sparseedm._validation`). Also a :class:`TypeError`, as in
    scikit-learn's ``InvalidParameterError``."""


class OutputPathError(SparseEDMError):
    """An output path that would overwrite an input or another output, or
    that cannot be created (its parent is a file, it is a directory, the
    format cannot be written under that name)."""


class ModelError(SparseEDMError):
    """A network model file (sparseedm.fconv) that is corrupt, unsafe, or does not fit."""


class EnvironmentSettingError(SparseEDMError):
    """An environment variable whose value cannot work (``NUMBA_NUM_THREADS=0``
    stops numba, which the solvers use, from loading); the message names it."""


class ConvergenceWarning(UserWarning):
    """A solver stopped before it could prove optimality."""
