"""The package version, in a module of its own: modules below the package root
import it from here, so importing one of them never runs ``sparseedm/__init__``'s
imports (celer's habit)."""

__version__ = "0.1.0"
