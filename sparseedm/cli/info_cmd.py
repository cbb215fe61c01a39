"""``sparseedm info DICT``: what a dictionary file holds, in words."""

from __future__ import annotations


def add_parser(sub):
    p = sub.add_parser("info", help="describe a dictionary or lifter file (or a shipped one by name)")
    p.add_argument("dictionary", nargs="?", default="default",
                   help="path to a dictionary or lifter .npz, or a shipped name "
                   "(default: default)")
    p.set_defaults(func=run)


def run(args):
    from ..dictionary import load_dictionary
    from ..lifting import is_lifter_file, load_lifter

    if is_lifter_file(args.dictionary):
        d = load_lifter(args.dictionary)
    else:
        d = load_dictionary(args.dictionary)
    print(f"{args.dictionary}:")
    print(d.describe())
    return 0
