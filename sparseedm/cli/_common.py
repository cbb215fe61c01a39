"""Options and helpers shared by the sub-commands."""

from __future__ import annotations

import sys


def add_quiet(parser):
    parser.add_argument("-q", "--quiet", action="store_true",
                        help="no progress bar (it is also off when stderr is not a terminal)")


def show_progress(args) -> bool:
    """Progress bars only for a person watching a terminal."""
    return not getattr(args, "quiet", False) and sys.stderr.isatty()
