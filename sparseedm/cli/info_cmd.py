"""``sparseedm info DICT``: what a dictionary (or FConv model) file holds, in words."""

from __future__ import annotations


def add_parser(sub):
    """Add the ``sparseedm info`` command, its options and help, to `sub`.

    Parameters
    ----------
    sub : argparse._SubParsersAction
        The ``sparseedm`` parser's sub-commands.
    """
    p = sub.add_parser("info", help="describe a dictionary, lifter or FConv model file (or a "
                       "shipped one by name)",
                       description="Print what a dictionary, lifter or FConv model file "
                       "holds: its size, alphas, normalisation, what it was learned from "
                       "and with which settings. Shipped dictionaries: default "
                       "(cmu-all-k2000, the base recover starts from), cmu-k2000, "
                       "cmu-coco-k2466, cmu-coco-k2932 (the prior of recover --no-adapt); "
                       "shipped lifter: cmu-lift (lift's default).")
    p.add_argument("dictionary", nargs="?", default="default", metavar="NAME|PATH",
                   help="a dictionary, lifter or FConv model .npz, or a shipped name "
                   "(default: default, the default dictionary)")
    p.set_defaults(func=run)


def run(args):
    """Run ``sparseedm info``: print what a dictionary, lifter or FConv model file holds.

    Parameters
    ----------
    args : argparse.Namespace
        The parsed command line.

    Returns
    -------
    int
        The exit code: 0 when done.
    """
    from ..dictionary import load_dictionary
    from ..exceptions import DictionaryError, ModelError
    from ..fconv.model import load_model  # no torch needed to read one
    from ..lifting import is_lifter_file, load_lifter

    if is_lifter_file(args.dictionary):
        d = load_lifter(args.dictionary)
    else:
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
