"""Reference pages generated from the code at build time.

* :func:`write_api_pages` writes one reST page per public module: the package
  root, every subpackage and every public module that defines ``__all__``, each
  listing its ``__all__`` in an ``autosummary`` table (so a new export appears
  in the reference by itself). Names are documented where they are defined:
  ``sparseedm.recover`` links to :func:`sparseedm.recovery.recover`.
* the ``cli-reference`` directive renders the ``sparseedm`` command's parser
  (``sparseedm.cli.build_parser``): every command's usage, description and
  options, exactly as ``--help`` prints them.
"""

from __future__ import annotations

import argparse
import importlib
import inspect
import pkgutil
import re
from pathlib import Path

from docutils import nodes
from docutils.parsers.rst import Directive

import sparseedm


#: top-level modules users import from directly (besides the root and the subpackages)
USER_MODULES = ("sparseedm.keypoints", "sparseedm.batch", "sparseedm.dictionary",
                "sparseedm.learning", "sparseedm.skeleton", "sparseedm.edm",
                "sparseedm.dataset", "sparseedm.exceptions", "sparseedm.uncertainty",
                "sparseedm.outliers")


def public_modules():
    """The package root, its subpackages and :data:`USER_MODULES` that define ``__all__``."""
    names = ["sparseedm"]
    for info in pkgutil.iter_modules(sparseedm.__path__, "sparseedm."):
        if not info.ispkg or info.name.split(".")[-1].startswith("_"):
            continue
        if info.name in ("sparseedm.cli", "sparseedm.dictionaries", "sparseedm.lifters"):
            continue
        names.append(info.name)
    names += USER_MODULES
    return [n for n in names if "__all__" in vars(importlib.import_module(n))]


def canonical(module, name):
    """(kind, full name) of ``module.name`` where it is defined."""
    obj = getattr(module, name)
    if inspect.ismodule(obj):
        return "module", obj.__name__
    home = getattr(obj, "__module__", None)
    if (inspect.isclass(obj) or inspect.isfunction(obj)) and home and home.startswith("sparseedm"):
        home_module = importlib.import_module(home)
        if getattr(home_module, obj.__name__, None) is obj and not name.startswith("__"):
            return ("class" if inspect.isclass(obj) else "function"), f"{home}.{obj.__name__}"
    return "data", f"{module.__name__}.{name}"


def _page(modname):
    module = importlib.import_module(modname)
    title = f"``{modname}``"
    lines = [title, "=" * len(title), "", f".. automodule:: {modname}", "   :no-members:", ""]
    groups = {"class": [], "function": [], "data": [], "module": []}
    for name in module.__all__:
        if name == "__version__":
            continue
        kind, full = canonical(module, name)
        if full not in groups[kind]:  # an alias documents its original once
            groups[kind].append(full)
    headings = {"class": "Classes", "function": "Functions", "data": "Constants",
                "module": "Modules"}
    for kind in ("function", "class", "data", "module"):
        if not groups[kind]:
            continue
        lines += [headings[kind], "-" * len(headings[kind]), ""]
        if kind == "module":
            lines += [f"* ``{full}``" for full in groups[kind]] + [""]
            continue
        template = {"class": "class.rst", "function": "function.rst", "data": "data.rst"}[kind]
        # autosummary prefixes the current module to every entry: name them from the root
        lines += [".. currentmodule:: sparseedm", "", ".. autosummary::", "   :toctree: generated",
                  f"   :template: {template}", ""]
        lines += [f"   ~{full.removeprefix('sparseedm.')}" for full in groups[kind]] + [""]
    return "\n".join(lines)


def write_api_pages(folder: Path):
    """Write ``folder/<module>.rst`` for every public module; return the module names."""
    folder.mkdir(parents=True, exist_ok=True)
    modules = public_modules()
    wanted = {f"{m}.rst" for m in modules}
    for old in folder.glob("*.rst"):
        if old.name not in wanted:
            old.unlink()
    for modname in modules:
        text = _page(modname)
        path = folder / f"{modname}.rst"
        if not path.exists() or path.read_text(encoding="utf-8") != text:
            path.write_text(text, encoding="utf-8")
    return modules


def constants(modules):
    """Documented names of the constants of `modules` (their docstring is their type's)."""
    names = set()
    for modname in modules:
        module = importlib.import_module(modname)
        for name in module.__all__:
            kind, full = canonical(module, name)
            if kind == "data":
                names.add(full)
    return names


def defined_in(prefixes):
    """Regexes matching the documented names of objects defined under `prefixes`."""
    return [rf"^{re.escape(p)}(\.|$)" for p in prefixes]


def _commands(parser, prog):
    yield prog, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for name, sub in action.choices.items():
                yield from _commands(sub, f"{prog} {name}")


class CliReference(Directive):
    """Every command of ``sparseedm``, with its ``--help``."""

    has_content = False

    def run(self):
        from sparseedm.cli import build_parser

        result = []
        for prog, parser in _commands(build_parser(), "sparseedm"):
            parser.prog = prog
            section = nodes.section(ids=[nodes.make_id(prog)])
            section += nodes.title(text=prog)
            parser.formatter_class = lambda prog: argparse.HelpFormatter(prog, width=92)
            text = parser.format_help()
            block = nodes.literal_block(text, text)
            block["language"] = "text"
            section += block
            result.append(section)
        return result


def setup(app):
    app.add_directive("cli-reference", CliReference)
    return {"parallel_read_safe": True, "parallel_write_safe": True}
