"""``sparseedm info DICT``: what a dictionary file holds, in words."""

from __future__ import annotations


def add_parser(sub):
    p = sub.add_parser("info", help="describe a dictionary file (or a shipped one by name)")
    p.add_argument("dictionary", nargs="?", default="default",
                   help="path to a dictionary .npz or a shipped name (default: default)")
    p.set_defaults(func=run)


def run(args):
    from ..dictionary import load_dictionary

    d = load_dictionary(args.dictionary)
    print(f"{args.dictionary}:")
    print(d.describe())
    return 0
