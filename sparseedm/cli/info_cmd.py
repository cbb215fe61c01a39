"""``sparseedm info DICT``: what a dictionary (or FConv model) file holds, in words."""

from __future__ import annotations


def add_parser(sub):
    p = sub.add_parser("info", help="describe a dictionary file (or a shipped one by name), "
                       "or an FConv model file")
    p.add_argument("dictionary", nargs="?", default="default",
                   help="path to a dictionary .npz or a shipped name (default: default)")
    p.set_defaults(func=run)


def run(args):
    from ..dictionary import load_dictionary
    from ..exceptions import DictionaryError, ModelError
    from ..fconv.model import load_model  # no torch needed to read one

    try:
        d = load_dictionary(args.dictionary)
    except DictionaryError as exc:
        try:  # an FConv model file (sparseedm fit-cnn)?
            d = load_model(args.dictionary)
        except ModelError:
            raise exc from None
    print(f"{args.dictionary}:")
    print(d.describe())
    return 0
