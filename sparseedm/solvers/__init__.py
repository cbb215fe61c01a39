"""Lasso backends behind one interface (see :mod:`.base`)."""

from .base import BaseSolver, LassoResult, duality_gap

SOLVERS = ("fast", "clarabel", "cvxpy-naive")


def get_solver(name_or_instance="fast", **kwargs):
    """A solver instance from its name (or the instance itself)."""
    if isinstance(name_or_instance, BaseSolver):
        return name_or_instance
    if name_or_instance == "fast":
        from .fast import FastSolver

        return FastSolver(**kwargs)
    if name_or_instance == "clarabel":
        from .clarabel import ClarabelSolver

        return ClarabelSolver(**kwargs)
    if name_or_instance == "cvxpy-naive":
        from .reference import NaiveCvxpySolver

        return NaiveCvxpySolver(**kwargs)
    raise ValueError(f"unknown solver {name_or_instance!r}; known: {', '.join(SOLVERS)}")


__all__ = ["BaseSolver", "LassoResult", "duality_gap", "get_solver", "SOLVERS"]
