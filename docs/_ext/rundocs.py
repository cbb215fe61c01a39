"""Executed code blocks for the documentation's pages.

Two MyST/reST directives whose code runs while the documentation builds, so every
command and every output a page shows comes from a real run:

``run-bash``
    One shell command per line (a trailing backslash continues it), run in the
    page's sandbox; the page shows each command after ``$`` and what it printed
    (stdout and stderr, in order). ``:returncode: N`` states the exit code the
    last command must give (default 0); any other exit code fails the build.
    ``:image: FILE`` shows the PNG the commands wrote there (a figure of
    ``sparseedm plot``), embedded in the page.
``run-python``
    Python source executed in a namespace shared by the page's ``run-python``
    blocks, with the sandbox as the current folder; the page shows the code and
    what it printed. ``:raises: NAME`` states the exception the block must raise
    (its message is shown, as a user would see it). ``:image: FILE`` as above.

The sandbox of a page is a fresh folder holding copies of the repository's
``examples/`` and ``tests/fixtures/``, so the commands read exactly as a user
runs them from the root of a clone; it lies beside the output folder
(``sandbox-html`` beside ``docs/_build/html``), one per output folder, so that
builds into different folders do not share it.
"""

from __future__ import annotations

import base64
import contextlib
import html
import io
import os
import shutil
import subprocess
import sys
import traceback
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import Directive, directives
from sphinx.util import logging

logger = logging.getLogger(__name__)
ROOT = Path(__file__).resolve().parents[2]
#: what a page's sandbox holds (copied from the repository)
SANDBOX_CONTENT = ("examples", "tests/fixtures")
MAX_OUTPUT_LINES = 60


def sandbox(env):
    """The current page's sandbox folder, made on its first use."""
    folder = env.temp_data.get("rundocs_sandbox")
    if folder is None:
        out = Path(env.app.outdir)
        base = out.parent / f"sandbox-{out.name}"  # one per output folder: builds side by side
        base.mkdir(parents=True, exist_ok=True)
        folder = base / env.docname.replace("/", "-")
        shutil.rmtree(folder, ignore_errors=True)
        folder.mkdir()
        for name in SANDBOX_CONTENT:
            shutil.copytree(ROOT / name, folder / name,
                            ignore=shutil.ignore_patterns("__pycache__", "*.py"))
        env.temp_data["rundocs_sandbox"] = folder
    return folder


def _shorten(text):
    lines = text.rstrip("\n").splitlines()
    if len(lines) > MAX_OUTPUT_LINES:
        cut = len(lines) - MAX_OUTPUT_LINES
        lines = lines[:MAX_OUTPUT_LINES] + [f"... ({cut} more lines)"]
    return "\n".join(lines)


def _commands(lines):
    commands, current = [], ""
    for line in lines:
        if not line.strip() and not current:
            continue
        current += line
        if current.endswith("\\"):
            current = current[:-1] + "\\\n"
            continue
        commands.append(current)
        current = ""
    if current:
        commands.append(current)
    return commands


def _image(env, lineno, name):
    """The PNG `name` of the page's sandbox, embedded in the HTML page (a list of
    nodes; none, with a build warning, when it was not written)."""
    path = sandbox(env) / name
    if not path.is_file():
        logger.warning("image %r was not written", name, location=(env.docname, lineno))
        return []
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    tag = (f'<img src="data:image/png;base64,{data}" alt="{html.escape(path.name)}" '
           'style="max-width: 100%">')
    return [nodes.raw("", tag, format="html")]


def _block(text, language):
    block = nodes.literal_block(text, text)
    block["language"] = language
    return block


class RunBash(Directive):
    """Run shell commands at build time and show them with their output."""

    has_content = True
    option_spec = {"returncode": int, "hide-output": directives.flag,
                   "image": directives.unchanged}

    def run(self):
        env = self.state.document.settings.env
        cwd = sandbox(env)
        commands = _commands(self.content)
        expected = self.options.get("returncode", 0)
        shown = []
        process_env = dict(os.environ, COLUMNS="100", PYTHONIOENCODING="utf-8",
                           PATH=os.pathsep.join([str(Path(sys.executable).parent),
                                                 os.environ.get("PATH", "")]))
        for k, command in enumerate(commands):
            done = subprocess.run(command, shell=True, cwd=cwd, env=process_env, text=True,
                                  stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                  timeout=900)
            want = expected if k == len(commands) - 1 else 0
            if done.returncode != want:
                logger.warning("run-bash: %r exited %d, expected %d:\n%s", command,
                               done.returncode, want, done.stdout,
                               location=(env.docname, self.lineno))
            shown.append("$ " + command)
            if done.stdout.strip() and "hide-output" not in self.options:
                shown.append(_shorten(done.stdout))
        result = [_block("\n".join(shown), "console")]
        if "image" in self.options:
            result.extend(_image(env, self.lineno, self.options["image"]))
        return result


class RunPython(Directive):
    """Execute Python at build time and show the code with what it printed."""

    has_content = True
    option_spec = {"raises": directives.unchanged, "image": directives.unchanged}

    def run(self):
        env = self.state.document.settings.env
        cwd = sandbox(env)
        namespace = env.temp_data.setdefault("rundocs_namespace", {"__name__": "__main__"})
        code = "\n".join(self.content)
        out = io.StringIO()
        raised = None
        before = os.getcwd()
        os.chdir(cwd)
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
                exec(compile(code, f"<{env.docname}:{self.lineno}>", "exec"), namespace)
        except Exception as exc:  # noqa: BLE001 - reported as a build warning below
            raised = exc
            trace = traceback.format_exc()
        finally:
            os.chdir(before)
        expected = self.options.get("raises")
        if raised is not None and type(raised).__name__ != expected:
            logger.warning("run-python raised:\n%s", trace, location=(env.docname, self.lineno))
        elif raised is None and expected:
            logger.warning("run-python: expected %s, nothing raised", expected,
                           location=(env.docname, self.lineno))
        result = [_block(code, "python")]
        printed = out.getvalue()
        if raised is not None:
            printed += f"{type(raised).__name__}: {raised}\n"
        if printed.strip():
            output = _block(_shorten(printed), "text")
            output["classes"].append("rundocs-output")
            result.append(output)
        if "image" in self.options:
            result.extend(_image(env, self.lineno, self.options["image"]))
        return result


def setup(app):
    app.add_directive("run-bash", RunBash)
    app.add_directive("run-python", RunPython)
    return {"parallel_read_safe": False, "parallel_write_safe": True}
