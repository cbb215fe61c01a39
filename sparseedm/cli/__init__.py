"""The ``sparseedm`` command line: a thin layer over the Python API.

Each sub-command lives in its own module with two functions,
``add_parser(subparsers)`` and ``run(args) -> int``; this module only wires
them together, so ``main([...])`` is what the tests call.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from .. import __version__
from ..exceptions import SparseEDMError

#: sub-command modules, in the order ``sparseedm --help`` lists them
COMMANDS = ("dataset", "fit", "info", "recover", "evaluate", "fit_cnn", "fit_lifter", "lift",
            "evaluate_lift")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="sparseedm",
        description="Recover occluded 2D pose joints from distance matrices by sparse coding.",
    )
    parser.add_argument("--version", action="version", version=f"sparseedm {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMANDS:
        try:
            module = importlib.import_module(f"{__name__}.{name}_cmd")
        except ModuleNotFoundError as exc:
            if exc.name != f"{__name__}.{name}_cmd":
                raise
            continue  # a command not built yet
        module.add_parser(sub)
    return parser


def main(argv=None) -> int:
    """Run the CLI; returns the exit code (0 ok, 1 partial failure, 2 bad input)."""
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    try:
        return int(args.func(args) or 0)
    except (SparseEDMError, OSError) as exc:  # bad input, or a file that cannot be made
        print(f"sparseedm {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"sparseedm {args.command}: interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
