"""The lasso layer: one public ``solve`` (in :mod:`.base`), one module per backend.

Backends by name (:data:`SOLVERS`):

* ``"clarabel"`` -- :class:`~sparseedm.solvers.clarabel.ClarabelSolver`
  (Clarabel interior point on small working sets, certified on the full lasso);
* ``"cvxpy-naive"`` -- :class:`~sparseedm.solvers.reference.NaiveCvxpySolver`
  (a fresh cvxpy problem per signal: the reference);
* ``"fast"`` -- ``sparseedm.solvers.fast.FastSolver`` (numba LARS), imported
  only when asked for.

Examples
--------
>>> from sparseedm.solvers import get_solver, SOLVERS
>>> SOLVERS
('clarabel', 'cvxpy-naive', 'fast')
>>> get_solver("clarabel", tol=1e-7).tol
1e-07
"""

from __future__ import annotations

import importlib

from ..exceptions import SparseEDMError
from .base import BaseSolver, LassoResult, duality_gap, lasso_objective

__all__ = [
    "SOLVERS",
    "get_solver",
    "BaseSolver",
    "LassoResult",
    "duality_gap",
    "lasso_objective",
]

#: name -> (module, class); modules are imported lazily by :func:`get_solver`.
_REGISTRY = {
    "clarabel": ("sparseedm.solvers.clarabel", "ClarabelSolver"),
    "cvxpy-naive": ("sparseedm.solvers.reference", "NaiveCvxpySolver"),
    "fast": ("sparseedm.solvers.fast", "FastSolver"),
}

#: Names :func:`get_solver` accepts.
SOLVERS = tuple(_REGISTRY)


def get_solver(name_or_instance="clarabel", **kwargs):
    """A solver from its name, or the given :class:`BaseSolver` unchanged.

    Parameters
    ----------
    name_or_instance : str or BaseSolver
        One of :data:`SOLVERS`, or an instance (returned as is; passing
        keyword arguments with an instance is an error).
    **kwargs
        Passed to the solver's constructor (e.g. ``tol``).

    Raises
    ------
    SparseEDMError
        Unknown name (the message lists the known ones), or a backend whose
        module cannot be imported.
    """
    if isinstance(name_or_instance, BaseSolver):
        if kwargs:
            raise SparseEDMError(
                "solver options cannot be applied to an existing solver instance; "
                f"got {sorted(kwargs)} with {type(name_or_instance).__name__}"
            )
        return name_or_instance
    if not isinstance(name_or_instance, str) or name_or_instance not in _REGISTRY:
        raise SparseEDMError(
            f"unknown solver {name_or_instance!r}; known solvers: " + ", ".join(SOLVERS)
        )
    module_name, class_name = _REGISTRY[name_or_instance]
    try:
        module = importlib.import_module(module_name)
        cls = getattr(module, class_name)
    except (ImportError, AttributeError) as exc:
        raise SparseEDMError(
            f"solver {name_or_instance!r} is not available: cannot import "
            f"{module_name}.{class_name} ({exc})"
        ) from exc
    return cls(**kwargs)
