"""A quick, seeded photo protocol on hand-annotated real people (benchmarks/real2d.py).

One file per source: C complete poses plus M other complete poses with joints
hidden, recovered in one call (the complete ones are what adaptation and
IterativeImputer learn from). Hidden: 1, 2 or 3 random joints per pose, or a
transplanted real mask (the unannotated-or-occluded pattern of another pose of
the same set, drawn at random among those that hide at least one joint and
leave at least 3). Score: the mean over every hidden joint of its error as a
percentage of the pose's body size (head top to the ankles' midpoint,
``real2d.body_size``).

Sources (validation splits only): ``mpii`` val, ``coco`` val + train (COCO's
subset has few complete poses), ``bonn`` val frames taken as photos (no tracks
or frames passed).

    python studies/real_prior/harness.py --methods iterative,cold,defaults
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from sparseedm._atomic import json_text  # noqa: E402

from benchmarks import real2d  # noqa: E402

PROTOCOLS = ("1", "2", "3", "real")
#: file -> (source, splits used, complete poses C, occluded poses M); "mpii-large"
#: is for settings that need a file of adaptation's size
FILES = {"mpii": ("mpii", ("val",), 200, 199), "coco": ("coco", ("val", "train"), 144, 144),
         "bonn": ("bonn", ("val",), 500, 500),
         "mpii-large": ("mpii", ("train", "val"), 800, 800),
         "coco-val": ("coco", ("val",), 27, 28)}


def real_patterns(realset):
    """Hidden-joint patterns of the set's poses: not visible, at least one, at least 3 left."""
    hidden = ~realset.visible
    keep = hidden.any(axis=1) & ((~hidden).sum(axis=1) >= 3)
    return hidden[keep]


def make_file(name, protocol, seed=0, sizes=None, realset=None):
    """``(truth (n, 14, 2), missing (n, 14))`` of the file `name` (:data:`FILES`);
    its occluded poses are the rows with a missing joint."""
    source, splits, C, M = FILES[name]
    rs = realset if realset is not None else real2d.load(source)
    if sizes is not None:
        C, M = sizes
    rows = np.flatnonzero(rs.complete & np.isin(real2d.split(rs), splits)
                          & (real2d.body_size(rs.poses) > 0))
    rng = np.random.default_rng([seed, PROTOCOLS.index(protocol)])
    rows = rng.permutation(rows)[: C + M]
    truth = rs.poses[rows]
    missing = np.zeros((len(rows), 14), bool)
    occ = np.arange(C, len(rows))
    if protocol == "real":
        pats = real_patterns(rs)
        missing[occ] = pats[rng.integers(len(pats), size=len(occ))]
    else:
        k = int(protocol)
        for i in occ:
            missing[i, rng.choice(14, size=k, replace=False)] = True
    return truth, missing


def score(filled, truth, missing):
    """Mean error of the hidden joints, % of body size."""
    size = real2d.body_size(truth)
    err = np.linalg.norm(filled - truth, axis=-1) / size[:, None] * 100
    return float(err[missing].mean())


def iterative(poses, missing):
    """IterativeImputer on the 28 pixel coordinates, fitted on the file."""
    from sklearn.experimental import enable_iterative_imputer  # noqa: F401
    from sklearn.impute import IterativeImputer

    X = np.where(missing[..., None], np.nan, poses).reshape(len(poses), -1)
    out = IterativeImputer(max_iter=10, tol=0, random_state=0).fit_transform(X)
    return out.reshape(poses.shape)


def sparse(**kwargs):
    """sparseedm.recover with `kwargs` as a method of the harness."""
    import sparseedm

    def run(poses, missing):
        res = sparseedm.recover(np.where(missing[..., None], np.nan, poses), missing,
                                **kwargs)
        return res.poses
    return run


def file_atoms(**kwargs):
    """The shipped prior plus the file's complete poses as atoms, no adaptation."""
    from sparseedm.dictionary import load_dictionary
    from sparseedm.file_atoms import with_file_atoms

    def run(poses, missing):
        d = with_file_atoms(load_dictionary(), poses, missing, **kwargs).dictionary
        return sparse(adapt=False, dictionary=d)(poses, missing)
    return run


METHODS = {"iterative": iterative, "cold": sparse(adapt=False), "defaults": sparse(),
           "file_atoms": file_atoms(), "file_atoms_filtered": file_atoms(filter=True)}


def run(methods, sources=("mpii", "coco", "bonn"), protocols=PROTOCOLS, seed=0, sizes=None):
    """``{source: {protocol: {method: % body size}}}`` and seconds per method."""
    table, seconds = {}, {}
    for source in sources:
        rs = real2d.load(FILES[source][0])
        for protocol in protocols:
            truth, missing = make_file(source, protocol, seed, sizes, rs)
            for name, method in methods.items():
                t0 = time.perf_counter()
                filled = method(truth, missing)
                seconds[name] = seconds.get(name, 0.0) + time.perf_counter() - t0
                table.setdefault(source, {}).setdefault(protocol, {})[name] = round(
                    score(filled, truth, missing), 3)
            print(source, protocol, table[source][protocol], flush=True)
    return table, seconds


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--methods", default="iterative,cold")
    ap.add_argument("--sources", default="mpii,coco,bonn")
    ap.add_argument("--protocols", default=",".join(PROTOCOLS))
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--out", type=Path)
    ap.add_argument("--dictionary", action="append", default=[], metavar="NAME=PATH",
                    help="add method NAME: recover(adapt=False) with the dictionary at PATH")
    ap.add_argument("--alpha", type=float, help="alpha of the --dictionary methods")
    ap.add_argument("--with-defaults", action="store_true",
                    help="also NAME_defaults: recover() with defaults and that dictionary")
    a = ap.parse_args(argv)
    methods = {m: METHODS[m] for m in a.methods.split(",") if m}
    for spec in a.dictionary:
        name, path = spec.split("=", 1)
        methods[name] = sparse(adapt=False, dictionary=path, alpha=a.alpha)
        if a.with_defaults:
            methods[f"{name}_defaults"] = sparse(dictionary=path, alpha=a.alpha)
    table, seconds = run(methods, a.sources.split(","), a.protocols.split(","), a.seed)
    doc = {"table": table, "seconds": {k: round(v, 1) for k, v in seconds.items()}}
    print(json.dumps(doc, indent=1))
    if a.out:
        a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
