"""The wheel ships the product only: the package's modules, the shipped
dictionaries and lifters (.npz) and the metadata.

The wheel is built by the build backend pyproject.toml names (setuptools'
``build_meta``, called in a subprocess, in a copy of the checkout so the build
leaves nothing behind) and its file list is read; the studies that chose the
shipped files, the benchmarks, the tests and the examples stay in the repository.
"""

from __future__ import annotations

import email
import shutil
import subprocess
import sys
import zipfile
from importlib import metadata
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: setuptools that reads pyproject.toml's SPDX licence field (PEP 639)
MIN_SETUPTOOLS = (77,)

#: left out of the copy: version control, virtualenvs, build outputs, caches
_NOT_COPIED = shutil.ignore_patterns(".git", ".ci-venv", ".venv", "venv*", "build", "dist",
                                     "*.egg-info", "__pycache__", ".pytest_cache",
                                     ".hypothesis", "out", "report")


def _setuptools_version():
    try:
        version = metadata.version("setuptools")
    except metadata.PackageNotFoundError:
        return None
    return tuple(int(p) for p in version.split(".")[:2] if p.isdigit())


@pytest.fixture(scope="module")
def wheel(tmp_path_factory):
    """The path of a wheel freshly built from this checkout."""
    version = _setuptools_version()
    if version is None or version < MIN_SETUPTOOLS:
        pytest.skip("the build backend is unavailable: setuptools>=77 (in the [test] extra) "
                    f"is not installed (found {version})")
    work = tmp_path_factory.mktemp("wheel")
    source, out = work / "source", work / "dist"
    shutil.copytree(ROOT, source, ignore=_NOT_COPIED)
    out.mkdir()
    build = ("import sys; from setuptools import build_meta; "
             "print(build_meta.build_wheel(sys.argv[1]))")
    done = subprocess.run([sys.executable, "-c", build, str(out)], cwd=source,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, f"the wheel did not build:\n{done.stderr[-3000:]}"
    return out / done.stdout.strip().splitlines()[-1]


@pytest.fixture(scope="module")
def wheel_names(wheel):
    """The file names inside the wheel."""
    with zipfile.ZipFile(wheel) as zf:
        return zf.namelist()


def _package_modules():
    """The wheel paths of the package's modules (sparseedm/ plus the two data packages)."""
    where = {"sparseedm": ROOT / "sparseedm", "sparseedm/dictionaries": ROOT / "dictionaries",
             "sparseedm/lifters": ROOT / "lifters"}
    out = set()
    for prefix, folder in where.items():
        pattern = "*.py" if prefix != "sparseedm" else "**/*.py"
        out.update(f"{prefix}/{p.relative_to(folder).as_posix()}" for p in folder.glob(pattern))
    return out


def _kind(name):
    """What a wheel entry is: 'module', 'data', 'metadata' or None (does not belong)."""
    top = name.split("/")[0]
    if top.endswith(".dist-info"):
        return "metadata"
    if top != "sparseedm":
        return None
    if name.endswith(".py"):
        return "module"
    if name.startswith(("sparseedm/dictionaries/", "sparseedm/lifters/")) and \
            name.endswith(".npz"):
        return "data"
    return None


def test_the_wheel_holds_only_modules_shipped_files_and_metadata(wheel_names):
    stray = [n for n in wheel_names if _kind(n) is None]
    assert not stray, f"files in the wheel that are not the product: {stray}"
    modules = {n for n in wheel_names if _kind(n) == "module"}
    assert modules == _package_modules(), (
        f"missing from the wheel: {sorted(_package_modules() - modules)}; "
        f"not a module of the package: {sorted(modules - _package_modules())}")


def test_the_wheel_ships_the_default_dictionary_and_lifter(wheel_names):
    data = {n for n in wheel_names if _kind(n) == "data"}
    shipped = {f"sparseedm/dictionaries/{p.name}" for p in (ROOT / "dictionaries").glob("*.npz")}
    shipped |= {f"sparseedm/lifters/{p.name}" for p in (ROOT / "lifters").glob("*.npz")}
    assert shipped and data == shipped


def test_no_study_benchmark_or_test_in_the_wheel(wheel_names):
    bad = [n for n in wheel_names
           if n.split("/")[0] in ("studies", "benchmarks", "tests", "examples", "docs")
           or Path(n).name.startswith(("select_", "probe_", "check_", "mirror_", "test_"))]
    assert not bad, f"development files in the wheel: {bad}"


@pytest.mark.parametrize("name, kind", [
    ("sparseedm/recovery.py", "module"), ("sparseedm/dictionaries/cmu-k2000.npz", "data"),
    ("sparseedm-0.1.0.dist-info/METADATA", "metadata"),
    ("sparseedm/dictionaries/README.md", None), ("studies/dictionary/select_alpha.py", None),
    ("sparseedm/lifters/selection.json", None), ("benchmarks/recovery.py", None),
])
def test_the_sorting_of_wheel_entries(name, kind):
    """The rule above tells the product from what is not (a planted stray is caught)."""
    assert _kind(name) == kind


def test_the_metadata_describes_the_project(wheel, wheel_names):
    name = next(n for n in wheel_names if n.endswith(".dist-info/METADATA"))
    with zipfile.ZipFile(wheel) as zf:
        info = email.message_from_bytes(zf.read(name))
    classifiers = info.get_all("Classifier") or []
    assert "Intended Audience :: Science/Research" in classifiers
    assert any(c.startswith("Development Status ::") for c in classifiers)
    assert info.get("License-Expression", info.get("License")) == "MIT"
    assert info.get("Keywords")
