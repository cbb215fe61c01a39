"""Why ``recover(adapt=False)`` loses to IterativeImputer on Bonn PoseTrack frames.

``harness.py``'s validation files (``bonn``: 500 complete + 500 occluded
validation frames taken as photos; ``mpii``: 200 + 199 validation images),
seeds 0..S-1, 1 / 2 / 3 random hidden joints and transplanted real masks.
Per file: the cold prior (``recover(adapt=False)``), IterativeImputer fitted on
the file (the benchmark's peer), IterativeImputer fitted on the file without
the rows of the occluded pose's own video (``ii_other_videos``: each video's
occluded poses filled by an imputer fitted on the other videos' rows) and the
nearest row of the file (KNNImputer, one neighbour). Per hidden joint and in
all: the mean error of the hidden joints, % of body size. Facts of each
source's validation complete poses: how many, from how many videos or
images, their body size in pixels, where the neck lies between the shoulders'
midpoint (0) and the head top (1), and how far each occluded pose's nearest
complete pose of the file is (observed joints, similarity-aligned, % of body
size).

    python studies/real_prior/probe_bonn_gap.py --seeds 1 --protocols 1,2,3 \\
        --out studies/real_prior/results_bonn_gap.json

``--oracle N``: instead, a bound on what any shipped prior of such people
could do (a diagnostic: Bonn data may never shape a shipped file): the
cold prior with N of Bonn's *train* split complete poses (other videos than
the file's) and their mirror images appended as atoms, ``mirror="auto"``,
against the cold prior and IterativeImputer on the same ``bonn`` files.

    python studies/real_prior/probe_bonn_gap.py --oracle 1500 --seeds 1 \\
        --protocols 1,3 --out studies/real_prior/results_bonn_oracle.json

``--train-complete C``: the benchmark's ``--complete-from train`` file
instead (C complete poses of Bonn's train videos + 500 occluded validation
frames): the cold prior, IterativeImputer on the file, and IterativeImputer
fitted on the file without the other occluded frames of the pose's own
video (the train poses kept).

    python studies/real_prior/probe_bonn_gap.py --train-complete 1000 --seeds 1 \\
        --protocols 1,2,3 --out studies/real_prior/results_bonn_train_complete.json
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[2]))

from benchmarks import real2d  # noqa: E402
from sparseedm._atomic import json_text  # noqa: E402
from sparseedm.skeleton import JOINT_NAMES  # noqa: E402
from studies.real_prior import harness  # noqa: E402


def file_rows(realset, name, protocol, seed):
    """The realset rows of ``harness.make_file(name, protocol, seed)``, in its order."""
    _, splits, C, M = harness.FILES[name]
    rows = np.flatnonzero(realset.complete & np.isin(real2d.split(realset), splits)
                          & (real2d.body_size(realset.poses) > 0))
    rng = np.random.default_rng([seed, harness.PROTOCOLS.index(protocol)])
    return rng.permutation(rows)[: C + M]


def imputer(X):
    from sklearn.experimental import enable_iterative_imputer  # noqa: F401
    from sklearn.impute import IterativeImputer

    return IterativeImputer(max_iter=10, tol=0, random_state=0).fit(X)


def fills(truth, missing, group):
    """{method: filled poses} on one file."""
    from sklearn.impute import KNNImputer

    X = np.where(missing[..., None], np.nan, truth).reshape(len(truth), -1)
    out = {"cold": harness.sparse(adapt=False)(truth, missing),
           "ii": imputer(X).transform(X).reshape(truth.shape),
           "nearest_row": KNNImputer(n_neighbors=1).fit_transform(X).reshape(truth.shape)}
    groups = np.unique(group[missing.any(axis=1)])
    if len(groups) < 20:  # videos: each one's occluded rows from the other videos' rows
        other = truth.copy()
        for g in groups:
            here = group == g
            other[here] = imputer(X[~here]).transform(X[here]).reshape(-1, 14, 2)
        out["ii_other_videos"] = other
    return out


def aligned_distance(a, b, seen):
    """Mean distance of the seen joints of pose `a` to `b`'s after a similarity fit."""
    A, B = a[seen], b[seen]
    A0, B0 = A - A.mean(0), B - B.mean(0)
    U, S, Vt = np.linalg.svd(B0.T @ A0)
    R = U @ Vt
    s = S.sum() / (B0 ** 2).sum()
    return float(np.linalg.norm(s * B0 @ R - A0, axis=1).mean())


def nearest_complete(truth, missing):
    """Per occluded pose, its nearest complete pose's aligned distance (% body size)."""
    size = real2d.body_size(truth)
    occ = np.flatnonzero(missing.any(axis=1))
    comp = np.flatnonzero(~missing.any(axis=1))
    return [min(aligned_distance(truth[i], truth[j], ~missing[i]) for j in comp)
            / size[i] * 100 for i in occ]


def facts(realset, name):
    """The validation complete poses of a source: count, groups, size, neck."""
    val = realset.complete & np.isin(real2d.split(realset), harness.FILES[name][1])
    P = realset.poses[val]
    mid = (P[:, 2] + P[:, 5]) / 2
    neck = np.linalg.norm(P[:, 1] - mid, axis=-1) / np.linalg.norm(P[:, 0] - mid, axis=-1)
    return dict(complete_poses=int(val.sum()), groups=int(len(np.unique(realset.group[val]))),
                body_px_median=round(float(np.median(real2d.body_size(P))), 1),
                neck_fraction_median=round(float(np.median(neck)), 3))


def probe(name, seeds, protocols):
    rs = real2d.load(harness.FILES[name][0])
    out = {"facts": facts(rs, name), "protocols": {}}
    near = []
    for protocol in protocols:
        errs = {}
        for seed in range(seeds):
            rows = file_rows(rs, name, protocol, seed)
            truth, missing = harness.make_file(name, protocol, seed, realset=rs)
            size = real2d.body_size(truth)
            for method, filled in fills(truth, missing, rs.group[rows]).items():
                e = np.linalg.norm(filled - truth, axis=-1) / size[:, None] * 100
                errs.setdefault(method, []).append(np.where(missing, e, np.nan))
            if protocol == "1" and seed == 0:
                near = nearest_complete(truth, missing)
        cell = {}
        for method, e in errs.items():
            e = np.concatenate(e)
            cell[method] = {"all": round(float(np.nanmean(e)), 2), "per_joint": {
                JOINT_NAMES[j]: round(float(np.nanmean(e[:, j])), 2) for j in range(14)}}
        out["protocols"][protocol] = cell
        print(name, protocol, {m: c["all"] for m, c in cell.items()}, flush=True)
    out["facts"]["nearest_complete_median"] = round(float(np.median(near)), 2)
    return out


def oracle(n_atoms, seeds, protocols):
    """{protocol: {method: error}} of the cold prior with Bonn train poses as atoms."""
    from sparseedm.dictionary import load_dictionary
    from sparseedm.file_atoms import with_file_atoms
    from sparseedm.skeleton import SKELETON_14

    rs = real2d.load("bonn")
    train = rs.poses[rs.complete & (real2d.split(rs) == "train")]
    some = train[np.sort(np.random.default_rng(0).permutation(len(train))[:n_atoms])]
    flipped = some[:, SKELETON_14.flip_permutation()].copy()
    flipped[..., 0] *= -1
    d = with_file_atoms(load_dictionary("cmu-coco-k2932"), np.concatenate([some, flipped]),
                        max_atoms=2 * n_atoms).dictionary
    out = {"train_complete_poses": int(len(train)), "atoms": int(d.n_components)}
    methods = {"cold": harness.sparse(adapt=False),
               "cold_with_bonn_train_atoms": harness.sparse(adapt=False, dictionary=d,
                                                            mirror="auto"),
               "ii": harness.iterative}
    for protocol in protocols:
        errs = {m: [] for m in methods}
        for seed in range(seeds):
            truth, missing = harness.make_file("bonn", protocol, seed, realset=rs)
            for m, f in methods.items():
                errs[m].append(harness.score(f(truth, missing), truth, missing))
        out[protocol] = {m: round(float(np.mean(e)), 2) for m, e in errs.items()}
        print("oracle", protocol, out[protocol], flush=True)
    return out


def train_complete(n_complete, seeds, protocols):
    """{protocol: {method: error}} on train complete + val occluded Bonn files."""
    rs = real2d.load("bonn")
    part = real2d.split(rs)
    ok = rs.complete & (real2d.body_size(rs.poses) > 0)
    out = {}
    for protocol in protocols:
        errs = {"cold": [], "ii": [], "ii_without_own_video_occluded": []}
        for seed in range(seeds):
            rng = np.random.default_rng([seed, harness.PROTOCOLS.index(protocol)])
            rows = np.concatenate([rng.permutation(np.flatnonzero(ok & (part == "train")))[
                :n_complete], rng.permutation(np.flatnonzero(ok & (part == "val")))[:500]])
            truth, group = rs.poses[rows], rs.group[rows]
            missing = np.zeros((len(rows), 14), bool)
            k = int(protocol)
            for i in range(n_complete, len(rows)):
                missing[i, rng.choice(14, size=k, replace=False)] = True
            X = np.where(missing[..., None], np.nan, truth).reshape(len(rows), -1)
            occ = missing.any(axis=1)
            own = truth.copy()
            for g in np.unique(group[occ]):
                here = group == g
                own[here] = imputer(X[~(here & occ)]).transform(X[here]).reshape(-1, 14, 2)
            for m, f in (("cold", harness.sparse(adapt=False)(truth, missing)),
                         ("ii", imputer(X).transform(X).reshape(truth.shape)),
                         ("ii_without_own_video_occluded", own)):
                errs[m].append(harness.score(f, truth, missing))
        out[protocol] = {m: round(float(np.mean(e)), 2) for m, e in errs.items()}
        print("train complete", protocol, out[protocol], flush=True)
    return out


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--files", default="bonn,mpii")
    ap.add_argument("--seeds", type=int, default=3)
    ap.add_argument("--protocols", default=",".join(harness.PROTOCOLS))
    ap.add_argument("--oracle", type=int, default=0, metavar="N")
    ap.add_argument("--train-complete", type=int, default=0, metavar="C")
    ap.add_argument("--out", type=Path)
    a = ap.parse_args(argv)
    if a.oracle or a.train_complete:
        doc = (oracle(a.oracle, a.seeds, a.protocols.split(",")) if a.oracle else
               train_complete(a.train_complete, a.seeds, a.protocols.split(",")))
        if a.out:
            a.out.write_text(json_text(doc, indent=1) + "\n")
        return
    doc = {}
    for n in a.files.split(","):
        doc[n] = probe(n, a.seeds, a.protocols.split(","))
        print(json.dumps(doc[n]["facts"], indent=1), flush=True)
        if a.out:
            a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
