"""From recovered distances to joints: other readouts of the same codes, on fixed recoveries.

``recover()`` places a pose's hidden joints by weighted least squares on
their recovered distances, the observed joints fixed
(:func:`sparseedm.placement.place_missing_joints`). This script runs the
default path once per file, keeps what its final recovery coded (each
member dictionary, each pose's code and completed EDM, the normalisation)
and reads the hidden joints out of them in other ways:

* ``w^p``: the least squares with residual weight ``d ** p`` (shipped p = 1);
* ``bones xF``: the distances along the skeleton's bones weighted F times more;
* ``spread``: each distance weighted by ``t ** 2 / (s ** 2 + t ** 2)``, ``s``
  the code-weighted spread of the used atoms' own distances for that entry
  (each atom scaled to the pose's observed distances), ``t`` their median
  (``spread t xF``: ``F t`` in the denominator; ``spread w^0``: times ``d ** 0``);
* ``huber``: the least squares with Huber weights (iteratively reweighted);
* ``atoms``: every used atom's pose (the classical MDS embedding of its
  distances; a file atom's is its pose) aligned to the observed joints
  (similarity Procrustes, reflection allowed), its hidden joints averaged
  with the code's weights (``|c|``);
* ``mds``: the classical MDS embedding of the whole completed EDM, aligned so;
* ``blend t``: ``t * atoms + (1 - t) * least squares``;
* ``ls from atoms`` / ``ls from mds``: the least squares started from their joints;
* ``blend 0.25 mds``, ``ls from atoms, blend 0.25``: the same blends of those.

Beside them, a diagnosis of the current readout on the first member: the
hidden-to-observed distances' mean error, the joints' mean error, their ratio,
the displacement of each joint that its distances' errors say (least squares
on the true directions to the observed joints) and the share of those errors
it explains.

Files (validation only): ``studies/fast/select_photo_atoms.py``'s photo files
(MPII, COCO, Bonn val occluded poses, mix and transplanted masks; complete
poses from the split itself, about 200 on MPII, or 1,000 from the train
split), CMU held-out clips (``select_fast.validation_file``) and Daz datasets
(``--daz``, Mix masks). Score: per occluded pose, the mean error of its
hidden joints (% of body size); ``candidate - current`` paired over the
occluded poses [mean, standard error]; IterativeImputer on the same file.

    python studies/real_prior/probe_readout.py --daz daz_indian.npz --out readout.json
    python studies/real_prior/probe_readout.py --table readout.json
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))
from sparseedm._atomic import json_text  # noqa: E402


# ----------------------------------------------------------------- capture
def capture(given, missing):
    """recover()'s defaults on the file, and its final recovery's members and settings."""
    import sparseedm
    import sparseedm.recovery as R

    box = {}
    orig = R.recover_members

    def spy(poses, miss, members, adaptations, **kw):
        box.update(poses=poses, missing=miss, members=list(members),
                   adaptations=list(adaptations), kw=dict(kw))
        return orig(poses, miss, members, adaptations, **kw)

    R.recover_members = spy
    try:
        res = sparseedm.recover(given, missing, n_jobs=2)
    finally:
        R.recover_members = orig
    return res, box


def code(box, d):
    """One member's coding of the file's poses: rows, normalised poses, completed
    vectors, codes, centre and scale (as recover_sparse computes them)."""
    from sparseedm._coding import atoms_key
    from sparseedm._recovery_base import bad_coordinates, screen
    from sparseedm._recovery_kernel import compiled_solver
    from sparseedm.edm import observed_entries
    from sparseedm.solvers import get_solver

    kw = box["kw"]
    poses, mask = box["poses"], box["missing"]
    solver = get_solver(compiled_solver(kw.get("solver", "fast"), box["adaptations"]))
    alpha = d.alpha_recover if kw.get("alpha") is None else kw["alpha"]
    positive = d.positive_code if kw.get("positive") is None else bool(kw["positive"])
    sc = screen(poses, mask, bad_coordinates(poses, mask), kw.get("representation", "average"),
                d.recovery_scale)
    todo = np.flatnonzero(sc.status == "recovered")
    X = sc.vectors[todo]
    observed = observed_entries(mask[todo])
    m = d.n_features
    alpha_eff = alpha * (observed.sum(1) / m if d.alpha_scaling == "entries"
                         else np.ones(len(todo)))
    res = solver.solve_masked(d.components.T, X, observed, alpha_eff, positive=positive,
                              key=atoms_key(d.components))
    coef = np.asarray(res.coef)
    merged = np.where(observed, X, coef @ d.components)
    normed = (sc.clean[todo] - sc.center[todo, None]) / sc.scale[todo, None, None]
    return dict(rows=todo, normed=normed, mask=mask[todo], vectors=merged, coef=coef,
                center=sc.center[todo], scale=sc.scale[todo])


# ----------------------------------------------------------------- geometry
def mds(edm):
    """Classical MDS of EDMs (..., N, N) -> (..., N, 2)."""
    N = edm.shape[-1]
    J = np.eye(N) - 1.0 / N
    B = -0.5 * J @ (edm ** 2) @ J
    w, V = np.linalg.eigh(B)
    return V[..., -2:] * np.sqrt(np.maximum(w[..., None, -2:], 0))


def align(src, dst, weight):
    """Similarity Procrustes (reflection allowed) of src onto dst over the joints of
    positive `weight`; src, dst (n, N, 2), weight (n, N) -> src moved (n, N, 2)."""
    w = weight / weight.sum(1, keepdims=True)
    ms = (w[..., None] * src).sum(1, keepdims=True)
    md = (w[..., None] * dst).sum(1, keepdims=True)
    A, B = src - ms, dst - md
    H = np.einsum("nj,nji,njk->nik", w, A, B)
    U, S, Vt = np.linalg.svd(H)
    R = U @ Vt
    s = S.sum(1) / np.maximum((w * (A ** 2).sum(-1)).sum(1), 1e-12)
    return s[:, None, None] * (A @ R) + md


def atoms_readout(c, emb, weight_rule="abs"):
    """Code-weighted mean of the used atoms' aligned poses (normalised units)."""
    normed, mask, coef = c["normed"], c["mask"], c["coef"]
    rows, atoms = np.nonzero(coef)
    w = np.abs(coef[rows, atoms]) if weight_rule == "abs" else np.maximum(coef[rows, atoms], 0)
    obs = (~mask[rows]).astype(float)
    moved = align(emb[atoms], np.nan_to_num(normed[rows]), obs)
    out = np.zeros(normed.shape)
    tot = np.zeros(len(normed))
    np.add.at(out, rows, w[:, None, None] * moved)
    np.add.at(tot, rows, w)
    return out / np.maximum(tot, 1e-12)[:, None, None]


def mds_readout(c):
    from sparseedm.edm import vector_to_edm

    return align(mds(vector_to_edm(c["vectors"])), np.nan_to_num(c["normed"]),
                 (~c["mask"]).astype(float))


def spread(c, components):
    """Per EDM entry: the code-weighted spread of the used atoms' distances, each atom
    scaled to the pose's observed entries (n, m)."""
    from sparseedm.edm import observed_entries

    coef, X = c["coef"], c["vectors"]
    obs = observed_entries(c["mask"])
    rows, atoms = np.nonzero(coef)
    D = components[atoms]  # (p, m)
    o = obs[rows]
    s = (D * X[rows] * o).sum(1) / np.maximum((D * D * o).sum(1), 1e-12)
    dev = (s[:, None] * D - X[rows]) ** 2
    w = np.abs(coef[rows, atoms])
    var = np.zeros(X.shape)
    tot = np.zeros(len(X))
    np.add.at(var, rows, w[:, None] * dev)
    np.add.at(tot, rows, w)
    return np.sqrt(var / np.maximum(tot, 1e-12)[:, None])


# ----------------------------------------------------------------- least squares
def place(normed, edm, mask, W=None, n_iter=10, start=None, huber=None, power=1.0):
    """place_missing_joints' least squares with per-entry weights `W` (n, N, N)
    times d ** power, optional start and Huber reweighting; per missing count."""
    from sparseedm.placement import place_missing_joints

    out = np.array(normed, float)
    counts = mask.sum(1)
    for k in np.unique(counts):
        r = np.flatnonzero(counts == k)
        out[r] = _place_batch(normed[r], edm[r], mask[r], None if W is None else W[r], n_iter,
                              None if start is None else start[r], huber, power)
    if W is None and start is None and huber is None and power == 1.0:  # sanity
        for k in np.unique(counts):
            r = np.flatnonzero(counts == k)
            ref = place_missing_joints(normed[r], edm[r], mask[r])
            assert np.allclose(ref, out[r][mask[r]].reshape(len(r), k, 2), atol=1e-9)
    return out


def _place_batch(poses, edm, missing, W, n_iter, start, huber, power):
    """One missing count: placement's start (or `start`) and its Gauss-Newton steps
    under weights ``W * d ** power``; with `huber`, reweighted before every step."""
    from sparseedm.placement import _gather, _refine, _trilaterate, _within_reach

    M = int(missing[0].sum())
    miss, anchors, d_mo, d_mm = _gather(poses, edm, missing)
    rows = np.arange(len(poses))[:, None]
    obs = np.argsort(~missing, axis=1, kind="stable")[:, M:]
    if start is None:
        P = np.stack([_trilaterate(anchors, d_mo[:, j]) for j in range(M)], axis=1)
        P = _within_reach(P, anchors, d_mo)
    else:
        P = start[rows, miss]
    iu, ju = np.triu_indices(M, 1)
    w_mo = np.maximum(d_mo, 1e-12) ** power
    w_mm = np.maximum(d_mm[:, iu, ju], 1e-12) ** power
    if W is not None:
        w_mo = w_mo * W[rows[:, :, None], miss[:, :, None], obs[:, None, :]]
        w_mm = w_mm * W[rows[:, :, None], miss[:, :, None], miss[:, None, :]][:, iu, ju]
    if huber is None:
        P = _refine(P, anchors, d_mo, d_mm, w_mo, w_mm, n_iter)
    for _ in range(n_iter if huber is not None else 0):
        r_mo = np.linalg.norm(P[:, :, None] - anchors[:, None], axis=-1) - d_mo
        r_mm = np.linalg.norm(P[:, iu] - P[:, ju], axis=-1) - d_mm[:, iu, ju]
        P = _refine(P, anchors, d_mo, d_mm,
                    w_mo * np.minimum(1, huber / np.maximum(np.abs(r_mo), 1e-12)),
                    w_mm * np.minimum(1, huber / np.maximum(np.abs(r_mm), 1e-12)), 1)
    out = poses.copy()
    out[rows, miss] = P
    return out


# ----------------------------------------------------------------- readouts
def bone_weights(n, factor):
    from sparseedm.skeleton import SKELETON_14

    W = np.ones((n, 14, 14))
    for j, p in enumerate(SKELETON_14.parents):
        if p is not None and p >= 0:
            W[:, j, p] = W[:, p, j] = factor
    return W


def readouts(c, d, emb):
    """{readout: joints (rows, 14, 2) in normalised units} of one member's coding."""
    from sparseedm.edm import vector_to_edm

    edm = vector_to_edm(c["vectors"])
    normed, mask = np.nan_to_num(c["normed"]), c["mask"]
    ls = place(normed, edm, mask)
    at = atoms_readout(c, emb)
    out = {"current": ls, "w^0": place(normed, edm, mask, power=0.0),
           "w^2": place(normed, edm, mask, power=2.0),
           "bones x3": place(normed, edm, mask, W=bone_weights(len(mask), 3.0)),
           "bones x10": place(normed, edm, mask, W=bone_weights(len(mask), 10.0))}
    s = vector_to_edm(spread(c, d.components))
    t = np.median(s[:, ~np.eye(14, dtype=bool)], axis=1)[:, None, None]
    out["spread"] = place(normed, edm, mask, W=1.0 / (s ** 2 + t ** 2) * t ** 2)
    for f in (0.5, 2.0):
        out[f"spread t x{f}"] = place(normed, edm, mask,
                                      W=1.0 / (s ** 2 + (f * t) ** 2) * t ** 2)
    out["spread w^0"] = place(normed, edm, mask, W=1.0 / (s ** 2 + t ** 2) * t ** 2, power=0.0)
    out["huber"] = place(normed, edm, mask, huber=0.02)
    out["atoms"] = at
    out["atoms c+"] = atoms_readout(c, emb, "pos")
    out["mds"] = mds_readout(c)
    for t in (0.25, 0.5, 0.75):
        out[f"blend {t}"] = t * at + (1 - t) * ls
    out["ls from atoms"] = place(normed, edm, mask, start=at)
    md = out["mds"]
    out["ls from mds"] = place(normed, edm, mask, start=md)
    out["blend 0.25 mds"] = 0.25 * md + 0.75 * ls
    out["ls from atoms, blend 0.25"] = 0.25 * at + 0.75 * out["ls from atoms"]
    for k in list(out):
        out[k] = np.where(mask[..., None], out[k], normed)
    return out


def member_embeddings(d):
    from sparseedm.edm import vector_to_edm

    return mds(vector_to_edm(d.components))


def diagnose(c, truth, ls):
    """How the current readout's hidden-joint errors relate to the recovered distances'
    errors (one member, normalised units): the mean error of the hidden-to-observed
    distances and of the joints, and the share of the distances' squared error that
    one displacement of the joint explains (the distances' errors projected on the
    true directions to the observed joints: a readout of these distances alone can
    undo only the rest)."""
    from sparseedm.edm import pose_to_edm, vector_to_edm

    T = (truth - c["center"][:, None]) / c["scale"][:, None, None]
    true_edm, edm = pose_to_edm(T), vector_to_edm(c["vectors"])
    d_err, j_err, shift, explained, total = [], [], [], 0.0, 0.0
    for i in range(len(T)):
        hid, obs = np.flatnonzero(c["mask"][i]), np.flatnonzero(~c["mask"][i])
        for j in hid:
            delta = edm[i, j, obs] - true_edm[i, j, obs]
            u = T[i, j] - T[i, obs]
            u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-12)
            e = np.linalg.lstsq(u, delta, rcond=None)[0]
            explained += float(((u @ e) ** 2).sum())
            total += float((delta ** 2).sum())
            d_err.append(np.abs(delta).mean())
            j_err.append(np.linalg.norm(ls[i, j] - T[i, j]))
            shift.append(np.linalg.norm(e))
    d_err, j_err = np.mean(d_err), np.mean(j_err)
    return {"distance_error": round(float(d_err), 5), "joint_error": round(float(j_err), 5),
            "ratio": round(float(j_err / d_err), 3),
            "displacement_the_distances_say": round(float(np.mean(shift)), 5),
            "explained_by_one_displacement": round(explained / total, 4)}


def per_pose(filled, truth, missing):
    from sparseedm.real_protocol import body_size

    err = np.linalg.norm(filled - truth, axis=-1) / body_size(truth)[:, None] * 100
    return np.nanmean(np.where(missing, err, np.nan), axis=1), err


def measure(truth, missing):
    """One file: each readout's error (mean over hidden joints; per pose) against current."""
    from studies.fast.select_photo_atoms import iterative

    given = np.where(missing[..., None], np.nan, truth)
    res, box = capture(given, missing)
    occ = missing.any(1)
    fills, diag = {}, None
    for d in box["members"]:
        c = code(box, d)
        got = readouts(c, d, member_embeddings(d))
        if diag is None:
            diag = diagnose(c, truth[c["rows"]], got["current"])
        for k, v in got.items():
            f = np.full(truth.shape, np.nan)
            f[c["rows"]] = v * c["scale"][:, None, None] + c["center"][:, None]
            fills.setdefault(k, []).append(f)
    fills = {k: np.mean(v, axis=0) for k, v in fills.items()}
    ok = np.isfinite(res.poses).all(axis=(1, 2)) & occ
    for k in fills:  # rows the default path did not place keep its answer
        fills[k] = np.where(np.isfinite(fills[k]), fills[k], res.poses)
    drift = float(np.nanmax(np.abs(fills["current"][ok] - res.poses[ok])))
    fills["iterative"] = iterative(given, missing)
    scores = {k: per_pose(v[ok], truth[ok], missing[ok]) for k, v in fills.items()}
    base = scores["current"][0]
    row = {"complete": int((~occ).sum()), "occluded": int(ok.sum()),
           "path": res.adaptation.summary()["path"] if res.adaptation else None,
           "members": len(box["members"]), "current_vs_recover_px": drift,
           "diagnosis_first_member": diag,
           "joints": {k: round(float(e[missing[ok]].mean()), 4) for k, (_, e) in scores.items()},
           "paired": {}}
    for k, (p, _) in scores.items():
        dd = p - base
        dd = dd[np.isfinite(dd)]
        row["paired"][k] = [round(float(dd.mean()), 4),
                            round(float(dd.std(ddof=1) / np.sqrt(len(dd))), 4)]
    return row


SHOWN = ("w^0", "w^2", "bones x3", "spread", "spread t x2.0", "huber", "atoms", "mds",
         "blend 0.25", "ls from atoms")


def table(doc):
    """Markdown: per file the current readout's and IterativeImputer's error (mean over
    hidden joints), the diagnosis and each readout's paired difference."""
    lines = ["| file | current | II | ratio | one displacement | "
             + " | ".join(SHOWN) + " |", "|---" * (5 + len(SHOWN)) + "|"]
    for name, r in doc["files"].items():
        g = r["diagnosis_first_member"]
        cells = [f"{r['paired'][k][0]:+.2f} ± {r['paired'][k][1]:.2f}" for k in SHOWN]
        lines.append(f"| {name} | {r['joints']['current']:.2f} | {r['joints']['iterative']:.2f}"
                     f" | {g['ratio']:.2f} | {g['explained_by_one_displacement']:.2f} | "
                     + " | ".join(cells) + " |")
    return "\n".join(lines)


def files(a):
    from studies.fast.select_default_exemplars import mocap_file
    from studies.fast.select_fast import validation_file
    from studies.fast.select_photo_atoms import photo_files

    for cf in filter(None, a.complete_from.split(",")):
        yield from photo_files(a.sources, "val", cf, sizes=(1000, 1000), seed=a.seed)
    for c in (int(x) for x in a.mocap_complete.split(",") if x):
        for seed in (2 * a.seed, 2 * a.seed + 1):
            P, mask = validation_file(2 * c, seed)
            yield f"cmu {len(P)} poses seed {seed}", np.asarray(P, float), mask
        for path in filter(None, a.daz.split(",")):
            truth, missing = mocap_file(path, c, a.occluded, a.seed)
            yield f"{Path(path).stem} {c}+{a.occluded}", np.asarray(truth, float), missing


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sources", default="mpii,coco,bonn")
    ap.add_argument("--complete-from", default="split,train")
    ap.add_argument("--mocap-complete", default="100,1000")
    ap.add_argument("--occluded", type=int, default=500)
    ap.add_argument("--daz", default="")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--only", default="", help="substring of the file names to run")
    ap.add_argument("--out", type=Path, default=Path("readout.json"))
    ap.add_argument("--table", type=Path, nargs="+", help="print the Markdown of these JSONs, stop")
    a = ap.parse_args(argv)
    if a.table:
        from studies.results_json import load_results  # null (NaN in strict JSON) read as NaN

        print(table({"files": {k: v for p in a.table
                               for k, v in load_results(p)["files"].items()}}))
        return
    warnings.simplefilter("ignore")
    doc = {"score": "per occluded pose: mean % body size of its hidden joints; paired: "
                    "[mean, standard error] of readout - current; joints: mean over hidden "
                    "joints", "files": {}}
    for name, truth, missing in files(a):
        if a.only and a.only not in name:
            continue
        doc["files"][name] = measure(truth, missing)
        r = doc["files"][name]
        print(name, r["path"], r["members"], f"drift {r['current_vs_recover_px']:.2g}",
              r["diagnosis_first_member"],
              json.dumps(r["paired"]), flush=True)
        a.out.write_text(json_text(doc, indent=1) + "\n")


if __name__ == "__main__":
    main()
