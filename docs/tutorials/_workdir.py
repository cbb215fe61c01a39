"""What every tutorial shares: a temporary work folder and a terminal-like ``sh``.

``work_folder(*paths)`` copies files of the repository (paths relative to its
root, found from the current folder upwards) into a new temporary folder;
``sh(command, work)`` runs a shell command there and prints what it prints, as
a terminal would, and fails unless it exits as expected.
"""

import shutil
import subprocess
import tempfile
from pathlib import Path


def repository():
    """The root of the clone this is run from (anywhere inside it)."""
    here = Path.cwd().resolve()
    for folder in (here, *here.parents):
        if (folder / "examples").is_dir() and (folder / "pyproject.toml").is_file():
            return folder
    raise SystemExit("run the tutorials from inside a clone of the sparseedm repository")


def work_folder(*paths, into=None):
    """A new temporary folder holding copies of `paths` (under `into`, if given)."""
    work = Path(tempfile.mkdtemp(prefix="sparseedm-tutorial-"))
    target = work / into if into else work
    target.mkdir(exist_ok=True)
    for path in paths:
        shutil.copy(repository() / path, target)
    return work


def sh(command, work, expect=0):
    """Run `command` in `work`, print it and its output; fail unless it exits `expect`."""
    print("$", command)
    done = subprocess.run(command, shell=True, cwd=work, text=True,
                          stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    print(done.stdout.rstrip())
    print(f"(exit code {done.returncode})")
    if done.returncode != expect:
        raise RuntimeError(f"{command!r} exited {done.returncode}, expected {expect}")
