"""The studies (studies/, not installed) still run from the repository root.

Each script under studies/ chose a shipped file or a default (the JSON beside
it is what it wrote). Every script's ``--help`` is run as ``python
studies/x/y.py --help`` would run it (one subprocess runs them all, each in a
fresh namespace), so a moved module or a renamed import fails here rather
than on the next rerun.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SCRIPTS = sorted(str(p.relative_to(ROOT)) for p in (ROOT / "studies").glob("*/*.py"))

#: runs each script's --help under runpy and prints {script: problem} of the failures
_RUN_ALL = r"""
import contextlib, io, json, runpy, sys
problems = {}
for script in sys.argv[1:]:
    sys.argv = [script, "--help"]
    out = io.StringIO()
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
            runpy.run_path(script, run_name="__main__")
        problems[script] = "no usage printed and no exit"
    except SystemExit as exc:
        if exc.code not in (0, None) or "usage:" not in out.getvalue():
            problems[script] = f"exit {exc.code}: {out.getvalue()[-300:]}"
    except Exception as exc:  # noqa: BLE001 - reported per script
        problems[script] = f"{type(exc).__name__}: {exc}"
print(json.dumps(problems))
"""


def test_the_studies_exist():
    assert len(SCRIPTS) >= 10 and all(s.startswith("studies/") for s in SCRIPTS)


def test_every_study_prints_its_help_from_the_repository_root():
    done = subprocess.run([sys.executable, "-c", _RUN_ALL, *SCRIPTS], cwd=ROOT,
                          capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    problems = json.loads(done.stdout.strip().splitlines()[-1])
    assert not problems, "studies that do not run:\n" + "\n".join(
        f"{s}: {p}" for s, p in problems.items())
