"""Old names kept as deprecated aliases, listed in one place.

A module that renamed a public name keeps the old one here (old name -> the
new name, both in that module) and sets its module-level ``__getattr__`` to
:func:`alias_getattr`: the old name still works and warns with the new path.

>>> ALIASES["sparseedm.fconv"]["lift"]
'lift_edm_vectors'
"""

from __future__ import annotations

import warnings

#: module -> {old name: its new name in the same module}
ALIASES = {
    # the FConv names before sparseedm.lifting had its own fit_lifter / lift
    # (which give a Lifter and a LiftResult, not an FConvModel and EDM vectors)
    "sparseedm.fconv": {"fit_lifter": "fit_edm_lifter", "lift": "lift_edm_vectors",
                        "FConvLifter": "FConvEDMLifter"},
    "sparseedm.fconv.training": {"fit_lifter": "fit_edm_lifter"},
    "sparseedm.fconv.lifting": {"lift": "lift_edm_vectors", "FConvLifter": "FConvEDMLifter"},
}


def alias_getattr(module, namespace):
    """A module ``__getattr__`` for `module` (its ``__name__``) whose globals are
    `namespace`: an old name of :data:`ALIASES` returns the new object with a
    DeprecationWarning naming the new path; any other name is an AttributeError.

    >>> get = alias_getattr("sparseedm.fconv.lifting", {"lift_edm_vectors": len})
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     get("lift") is len, str(caught[0].message)
    (True, 'sparseedm.fconv.lifting.lift is deprecated; use sparseedm.fconv.lifting.lift_edm_vectors')
    """
    aliases = ALIASES.get(module, {})

    def __getattr__(name):
        new = aliases.get(name)
        if new is None:
            raise AttributeError(f"module {module!r} has no attribute {name!r}")
        warnings.warn(f"{module}.{name} is deprecated; use {module}.{new}",
                      DeprecationWarning, stacklevel=2)
        return namespace[new]

    return __getattr__
