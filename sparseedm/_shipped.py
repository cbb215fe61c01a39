"""Files shipped inside the package (dictionaries, lifters), found by name or path."""

from __future__ import annotations

import errno
import os
from importlib import resources
from pathlib import Path


def shipped_names(package: str, default: str) -> list[str]:
    """Names of the .npz files shipped in `package` ("default" first when `default` is one)."""
    try:
        names = sorted(p.name[:-4] for p in resources.files(package).iterdir()
                       if p.name.endswith(".npz"))
    except ModuleNotFoundError:  # pragma: no cover - a broken install
        names = []
    return ["default"] + names if default in names else names


def resolve_shipped(name_or_path, package: str, default: str, error, what: str) -> Path:
    """The path of a shipped file by name (None or "default" for `default`), or a path.

    A name that is neither a shipped file nor looks like a path raises
    ``error`` naming the shipped ones.
    """
    if name_or_path is None or name_or_path == "default":
        name_or_path = default
    path = Path(name_or_path)
    try:
        exists = os.path.lexists(path)
        if len(os.fsencode(path.name)) > 255:
            raise OSError(errno.ENAMETOOLONG, "File name too long")
    except OSError as exc:  # a 5000-character name
        raise error(f"{str(name_or_path)[:60]}...: not a {what} name or path "
                    f"({exc.strerror})") from None
    if path.suffix == ".npz" or exists or "/" in str(name_or_path):
        return path
    res = resources.files(package) / f"{name_or_path}.npz"
    if not res.is_file():
        raise error(f"no {what} called {name_or_path!r}; shipped ones: "
                    f"{', '.join(shipped_names(package, default)) or 'none'}; "
                    "or give a path to an .npz")
    return Path(str(res))
