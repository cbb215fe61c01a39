"""The public API: what the package's ``__init__`` files export.

Every name a module's ``__all__`` lists exists; the subpackages' exports
import without loading what sits above them; the old names kept as aliases
(:data:`sparseedm._deprecated.ALIASES`) still work and warn with the new path;
and the docs' API list, once there is one, names every public module.
"""

from __future__ import annotations

import importlib
import subprocess
import sys
import warnings
from pathlib import Path

import pytest

from sparseedm._deprecated import ALIASES

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "sparseedm"

#: the packages users import names from
PACKAGES = ("sparseedm", "sparseedm.temporal", "sparseedm.lifting", "sparseedm.formats",
            "sparseedm.solvers", "sparseedm.mocap", "sparseedm.fconv")


def _modules():
    """Every module of the package by dotted name."""
    out = []
    for path in sorted(PACKAGE.rglob("*.py")):
        parts = list(path.relative_to(ROOT).with_suffix("").parts)
        if parts[-1] == "__init__":
            parts.pop()
        out.append(".".join(parts))
    return out


def _public(module):
    """A module users may import: no part of its path starts with an underscore."""
    return not any(p.startswith("_") for p in module.split("."))


# ``python -m sparseedm``'s entry point runs the command line on import
@pytest.mark.parametrize("name", [m for m in _modules() if m != "sparseedm.__main__"])
def test_every_name_in_all_exists(name):
    module = importlib.import_module(name)
    listed = getattr(module, "__all__", [])
    assert len(set(listed)) == len(listed), f"{name}.__all__ repeats a name"
    with warnings.catch_warnings():
        warnings.simplefilter("error", DeprecationWarning)  # no deprecated name is listed
        missing = [n for n in listed if not hasattr(module, n)]
    assert not missing, f"{name}.__all__ lists names it does not have: {missing}"


@pytest.mark.parametrize("name", PACKAGES)
def test_the_packages_export_their_public_names(name):
    module = importlib.import_module(name)
    assert module.__all__, f"{name} exports nothing"
    assert set(module.__all__) <= set(dir(module))


@pytest.mark.parametrize("name", ["recover_temporal", "TemporalResult", "recover_track",
                                  "link_tracks", "fill_linear", "fill_pca", "FILLERS",
                                  "evaluate_video", "gap_mask", "load_sequences"])
def test_temporal_exports_what_a_video_user_needs(name):
    import sparseedm.temporal

    assert name in sparseedm.temporal.__all__
    value = getattr(sparseedm.temporal, name)
    assert getattr(value, "__module__", "sparseedm.temporal.").startswith("sparseedm.temporal.")


def test_importing_the_package_does_not_load_what_the_exports_defer():
    """recover() imports sparseedm.temporal; the video evaluation above it (and the
    lifting workflows) load only when one of their names is used."""
    deferred = ["sparseedm.temporal.fillers", "sparseedm.temporal.evaluation",
                "sparseedm.lifting.io", "sparseedm.lifting.evaluation"]
    code = ("import sys, sparseedm, sparseedm.temporal, sparseedm.lifting\n"
            f"deferred = {deferred!r}\n"
            "print([m for m in deferred if m in sys.modules])\n"
            "sparseedm.temporal.evaluate_video, sparseedm.lifting.lift_file\n"
            "print([m for m in deferred if m in sys.modules])\n")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          check=True, cwd=ROOT)
    before, after = done.stdout.splitlines()
    assert before == "[]"
    assert after == repr(deferred)


def test_an_unknown_name_is_an_attribute_error():
    import sparseedm.fconv
    import sparseedm.temporal

    for module in (sparseedm.temporal, sparseedm.fconv, sparseedm.lifting):
        with pytest.raises(AttributeError, match="no_such_name"):
            module.no_such_name


@pytest.mark.parametrize("module, old, new", [
    (module, old, new) for module, names in ALIASES.items() for old, new in names.items()])
def test_an_old_name_works_and_warns_with_the_new_path(module, old, new):
    mod = importlib.import_module(module)
    with pytest.warns(DeprecationWarning, match=rf"{module}\.{old} is deprecated; "
                                                rf"use {module}\.{new}$"):
        value = getattr(mod, old)
    assert value is getattr(mod, new)
    assert old not in mod.__all__


def test_from_import_of_an_old_name_warns():
    with pytest.warns(DeprecationWarning, match="sparseedm.fconv.fit_edm_lifter"):
        from sparseedm.fconv import fit_lifter
    from sparseedm.fconv import fit_edm_lifter

    assert fit_lifter is fit_edm_lifter
