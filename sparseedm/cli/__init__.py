"""The ``sparseedm`` command line: a thin layer over the Python API.

Each sub-command lives in its own module with two functions,
``add_parser(subparsers)`` and ``run(args) -> int``; this module only wires
them together, so ``main([...])`` is what the tests call.

Exit codes, one per outcome: 0 every row done, 1 some rows refused (outputs
written, the errors file lists them), 2 bad input or arguments (nothing
written), 3 an internal error (a bug: one line on stderr; ``--debug`` prints
the traceback), 130 interrupted.
"""

from __future__ import annotations

import argparse
import difflib
import importlib
import os
import re
import sys
import traceback
import warnings

from .. import _progress
from .._version import __version__
from .._validation import environment_problem
from ..exceptions import EnvironmentSettingError, SparseEDMError

#: sub-command modules, in the order ``sparseedm --help`` lists them
COMMANDS = ("dataset", "fit", "info", "recover", "plot", "evaluate", "fit_cnn", "fit_lifter",
            "lift", "evaluate_lift")

#: exit codes (see the module docstring)
EXIT_OK, EXIT_REFUSED_ROWS, EXIT_BAD_INPUT, EXIT_INTERNAL, EXIT_INTERRUPTED = 0, 1, 2, 3, 130
#: the package's folder: warnings raised from inside it are shown as one line
_PACKAGE = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
_EPILOG = ("exit codes: 0 every row done; 1 some rows refused or input files unreadable "
           "(outputs written, the errors file lists them); 2 bad input or arguments "
           "(nothing written); 3 internal error (a bug: rerun with --debug for the "
           "traceback); 130 interrupted")


class _Parser(argparse.ArgumentParser):
    """argparse's parser, whose errors suggest the nearest command, option or choice
    (``did you mean 'recover'?``); its sub-command parsers are of this class too."""

    def parse_args(self, args=None, namespace=None):
        args, extras = self.parse_known_args(args, namespace)
        if extras:  # said by the sub-command that was given them, with its options
            _chosen(self, args).error(f"unrecognized arguments: {' '.join(extras)}")
        return args

    def error(self, message):
        super().error(message + _did_you_mean(self, message))


def _chosen(parser, args):
    """The innermost (sub-)command parser the parsed `args` went through."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            name = getattr(args, action.dest, None)
            if name in action.choices:
                return _chosen(action.choices[name], args)
    return parser


def _did_you_mean(parser, message) -> str:
    """``"; did you mean ...?"`` for an unknown choice (a command, an option's value)
    or unknown options in argparse's `message`, from `parser`'s own; else "".

    >>> p = _Parser(prog="x")
    >>> _ = p.add_argument("--solver", choices=("fast", "clarabel"))
    >>> _did_you_mean(p, "argument --solver: invalid choice: 'fsat' (choose from ...)")
    "; did you mean 'fast'?"
    >>> _did_you_mean(p, "unrecognized arguments: --solvr=fast 3")
    "; did you mean '--solver'?"
    """
    choice = re.search(r"argument (\S+): invalid choice: (['\"]?)(.*?)\2 \(", message)
    if choice:
        name, words = choice.group(1), [choice.group(3)]
        pool = [str(c) for a in parser._actions if a.choices is not None
                and name in (*a.option_strings, a.metavar, a.dest) for c in a.choices]
    elif message.startswith("unrecognized arguments: "):
        words = [w.split("=", 1)[0] for w in message.split(": ", 1)[1].split()
                 if w.startswith("-")]
        pool = [o for a in parser._actions for o in a.option_strings
                if not isinstance(a, argparse._HelpAction)]
    else:
        return ""
    close = [m for w in words for m in difflib.get_close_matches(w, pool, n=2, cutoff=0.6)]
    close = list(dict.fromkeys(close))
    return f"; did you mean {' or '.join(map(repr, close))}?" if close else ""


def build_parser() -> argparse.ArgumentParser:
    """The ``sparseedm`` parser: every command's options, help and exit codes.

    Commands whose module is not there are left out; ``--debug`` is accepted
    after every command's name.

    Returns
    -------
    argparse.ArgumentParser
        The parser; its errors suggest the nearest command, option or choice.
    """
    parser = _Parser(
        prog="sparseedm",
        description="Recover occluded 2D pose joints from distance matrices by sparse coding.",
        epilog=_EPILOG,
    )
    parser.add_argument("--version", action="version", version=f"sparseedm {__version__}")
    parser.add_argument("--debug", action="store_true",
                        help="print the traceback of an internal error (exit code 3)")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"{__name__}.{name}_cmd")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}_cmd":
                raise
            continue  # a command not built yet
        module.add_parser(sub)
    _add_debug(parser)
    return parser


def _add_debug(parser):
    """``--debug`` after every (nested) command's name too, and the exit codes in its help."""
    for action in parser._actions:
        if not isinstance(action, argparse._SubParsersAction):
            continue
        for command in action.choices.values():
            command.epilog = command.epilog or _EPILOG
            command.add_argument("--debug", action="store_true", default=argparse.SUPPRESS,
                                 help="print the traceback of an internal error (exit code 3)")
            _add_debug(command)


def main(argv=None) -> int:
    """Run the CLI; returns the exit code (0 ok, 1 some rows refused, 2 bad input,
    3 internal error, 130 interrupted).

    Parameters
    ----------
    argv : list of str, optional
        The arguments after ``sparseedm``; default ``sys.argv[1:]``.

    Returns
    -------
    int
        The exit code.
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return EXIT_BAD_INPUT
    # long stages say what they are doing on stderr (a bar on a terminal) unless --quiet
    _progress.enable(not getattr(args, "quiet", False))
    try:
        _refuse_environment()
        _refuse_dash(args)
        with warnings.catch_warnings():  # the API's warnings, one clean line each
            warnings.showwarning = _warning_line(args.command)
            return int(args.func(args) or 0)
    except BrokenPipeError:  # e.g. `sparseedm info default | head`: the reader has enough
        _silence_stdout()
        return 0
    except (SparseEDMError, OSError) as exc:  # bad input, or a file that cannot be made
        print(f"sparseedm {args.command}: error: {_one_line(exc)}", file=sys.stderr)
        return EXIT_BAD_INPUT
    except KeyboardInterrupt:
        print(f"sparseedm {args.command}: interrupted", file=sys.stderr)
        return EXIT_INTERRUPTED
    except Warning as exc:  # the user's filters (PYTHONWARNINGS=error, -W error) stop the run
        kind = "" if type(exc) is UserWarning else f"{type(exc).__name__}: "
        print(f"sparseedm {args.command}: error: {kind}{_one_line(exc)} (a warning, raised "
              "as an error by the warning filters: PYTHONWARNINGS or -W)", file=sys.stderr)
        return EXIT_BAD_INPUT
    except Exception as exc:  # noqa: BLE001 - a bug must never read as rows refused
        return _internal_error(args, exc)
    finally:
        _progress.enable(False)


#: options that name a file a command writes
_OUTPUT_OPTIONS = {"output": "-o", "errors": "--errors", "save_dictionary": "--save-dictionary",
                   "checkpoint": "--checkpoint", "plot": "--plot", "write_map": "--write-map"}


def _refuse_environment():
    """An environment variable that stops a dependency from loading: bad input
    (exit 2, its name and value said), never a traceback."""
    problem = environment_problem()
    if problem:
        raise EnvironmentSettingError(problem)


def _refuse_dash(args):
    """``-o -`` is not standard output here (outputs land at exactly the path
    given): refused rather than written to a file called ``-``."""
    for dest, option in _OUTPUT_OPTIONS.items():
        if getattr(args, dest, None) == "-":
            raise SparseEDMError(f"{option} -: '-' is not standard output here; give "
                                 f"{option} /dev/stdout to write there, or {option} ./- "
                                 "for a file named '-'")


def _one_line(exc) -> str:
    return " ".join(str(exc).split()) or type(exc).__name__


def _warning_line(command):
    """A :func:`warnings.showwarning` for one command's run: a warning raised
    inside sparseedm (a skipped OpenPose frame file, ...) as one line on stderr,
    ``sparseedm <command>: warning: <message>``, without Python's file, line
    number and source line; any other library's as Python shows it.

    >>> import io
    >>> out = io.StringIO()
    >>> _warning_line("recover")("skipped a.json: invalid JSON", UserWarning,
    ...                          os.path.join(_PACKAGE, "keypoints.py"), 466, out)
    >>> out.getvalue()
    'sparseedm recover: warning: skipped a.json: invalid JSON\\n'
    """
    plain = warnings.showwarning

    def show(message, category, filename, lineno, file=None, line=None):
        if not os.path.abspath(str(filename)).startswith(_PACKAGE + os.sep):
            plain(message, category, filename, lineno, file, line)
            return
        kind = "" if category is UserWarning else f"{category.__name__}: "
        print(f"sparseedm {command}: warning: {kind}{_one_line(message)}",
              file=sys.stderr if file is None else file)

    return show


def _internal_error(args, exc) -> int:
    """One line on stderr (the traceback with --debug); exit code 3."""
    if getattr(args, "debug", False):
        traceback.print_exc()
    what = "out of memory" if isinstance(exc, MemoryError) else type(exc).__name__
    print(f"sparseedm {args.command}: internal error ({what}: {_one_line(exc)[:300]}); "
          "this is a bug, please report it" + ("" if getattr(args, "debug", False) else
                                               " with the output of --debug"),
          file=sys.stderr)
    return EXIT_INTERNAL


def _silence_stdout():
    """Point stdout at /dev/null, so that the interpreter's final flush into the
    closed pipe does not print a second BrokenPipeError."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError):  # no real stdout (e.g. captured): nothing to flush
        pass


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
