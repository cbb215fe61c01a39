"""Every code block of README.md runs, and every block of docs/ is executed.

README.md's ```bash and ```python blocks are extracted and run here, in a
temporary copy of the files they use (``examples/``). The documentation's
pages under ``docs/`` show code only through directives that run it while the
site builds (``run-bash``, ``run-python``; the tutorials are executed by
sphinx-gallery), so a plain ```bash or ```python block there is a block nobody
runs: this test finds them.

A block is left out only with a ``<!-- not run: REASON -->`` line right above
it, and only for an install command; the blocks left out are listed below and
counted. README.md's "Two commands" block is run by ``.ci/run`` and
tests/test_readme.py, not here.
"""

import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
FENCE = re.compile(r"^```(\w+)\s*$")
MARKER = re.compile(r"^<!-- not run: (.+) -->$")
#: blocks left out on purpose: (file, first line of the block)
NOT_RUN = {
    ("README.md", 'pip install -e ".[docs]" && sphinx-build -W --keep-going -b html docs docs/_build/html'),
    ("docs/getting-started.md", "pip install -e ."),
}


def blocks(path):
    """(language, code, reason-not-run or None, section) of each fenced block of `path`."""
    found, section, reason = [], "", None
    lines = path.read_text(encoding="utf-8").splitlines()
    k = 0
    while k < len(lines):
        line = lines[k]
        if line.startswith("## "):
            section = line[3:]
        marker = MARKER.match(line)
        if marker:
            reason = marker.group(1)
            k += 1
            continue
        fence = FENCE.match(line)
        if fence:
            end = lines.index("```", k + 1)
            found.append((fence.group(1), "\n".join(lines[k + 1:end]), reason, section))
            reason, k = None, end + 1
            continue
        if line.strip():
            reason = None
        k += 1
    return found


def readme_blocks():
    return [(lang, code) for lang, code, reason, section in blocks(ROOT / "README.md")
            if lang in ("bash", "python") and reason is None and section != "Two commands"]


def docs_pages():
    return sorted(p for p in (ROOT / "docs").rglob("*.md") if "_build" not in p.parts)


def test_blocks_left_out_are_install_commands_and_listed():
    left_out = set()
    for path in [ROOT / "README.md", *docs_pages()]:
        for lang, code, reason, _ in blocks(path):
            if reason is not None:
                assert "install" in reason and "pip install" in code, (path, code)
                left_out.add((path.relative_to(ROOT).as_posix(), code.splitlines()[0]))
    assert left_out == NOT_RUN


def test_docs_pages_show_no_code_that_is_not_run():
    plain = [(p.relative_to(ROOT).as_posix(), code.splitlines()[0])
             for p in docs_pages() for lang, code, reason, _ in blocks(p)
             if lang in ("bash", "python", "console", "sh", "shell") and reason is None]
    assert plain == [], "use run-bash / run-python so the build runs them"


def test_readme_has_a_python_and_a_bash_block():
    langs = [lang for lang, _ in readme_blocks()]
    assert "bash" in langs and "python" in langs


@pytest.mark.parametrize("lang,code", readme_blocks(),
                         ids=lambda v: v if v in ("bash", "python") else None)
def test_readme_block_runs(lang, code, tmp_path):
    shutil.copytree(ROOT / "examples", tmp_path / "examples",
                    ignore=shutil.ignore_patterns("__pycache__"))
    bindir = str(Path(sys.executable).parent)
    if lang == "bash" and not shutil.which("sparseedm", path=bindir):
        pytest.skip("the sparseedm console script is not installed (pip install -e .)")
    env = dict(os.environ, PATH=os.pathsep.join([bindir, os.environ.get("PATH", "")]))
    command = ["bash", "-euo", "pipefail", "-c", code] if lang == "bash" else [
        sys.executable, "-c", code]
    done = subprocess.run(command, cwd=tmp_path, env=env, capture_output=True, text=True,
                          timeout=900)
    assert done.returncode == 0, done.stdout + done.stderr
