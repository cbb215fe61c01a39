"""Dictionary learning: sparseedm's online learner vs SPAMS trainDL (vs scikit-learn).

All learners get the same thing: the complete, normalised EDM vectors of the
CMU training clips (the held-out clips of :func:`benchmarks.split_clips` left
out), the same k, batch size 512, one pass (the same number of mini-batches),
the same initial atoms, and the same per-sample objective
``0.5 ||x - D c||^2 + alpha ||c||_1`` (SPAMS ``mode=2``, its default
``lambda2=1e-9`` elastic-net term aside; scikit-learn's ``alpha`` is per sample
too). Each dictionary is then judged on the held-out clips: the Mix protocol
(1-3 occluded joints, ``random_occlusion(n, 14, "mix", random_state=0)``)
through ``sparseedm.recover`` with the fast solver, Err_ave in percent, and
the mean lasso objective of the complete held-out vectors.

    python -m benchmarks.fit [--quick]
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from sparseedm.dictionary import Dictionary
from sparseedm.edm import pose_to_vector
from sparseedm.learning import (OnlineDictionaryLearning, complete_pose_vectors,
                                init_dictionary, sparse_code)
from sparseedm.metrics import err_ave, random_occlusion
from sparseedm.recovery import recover

from . import alphas, held_out_sample, load_cmu, log, split_clips

FULL = dict(k=2000, n_heldout=2000, sklearn_budget_s=45.0, spams_cap_s=240.0)
QUICK = dict(k=200, n_heldout=200, sklearn_budget_s=1.5, spams_cap_s=20.0)


def _unit_rows(components):
    """Unit-norm rows (SPAMS and scikit-learn keep atoms *inside* the unit ball);
    rows of zero norm are dropped. Returns (components, n_dropped, min_norm)."""
    norms = np.linalg.norm(components, axis=1)
    keep = norms > 1e-10
    return components[keep] / norms[keep, None], int((~keep).sum()), float(norms[keep].min())


def evaluate(components, alpha_train, alpha_recover, val_poses, mask, gt):
    """Held-out Mix Err_ave (%) and mean held-out lasso objective of one dictionary."""
    d = Dictionary(components, alpha_recover=alpha_recover, alpha_train=alpha_train)
    res = recover(np.where(mask[..., None], np.nan, val_poses), mask, dictionary=d,
                  solver="fast")
    err = float(np.nanmean(err_ave(res.vectors * res.scale[:, None], gt)))
    Xv, _ = complete_pose_vectors(val_poses)
    code = sparse_code(Xv, d.components, alpha_train)
    R = Xv - code @ d.components
    obj = float(np.mean(0.5 * (R * R).sum(1) + alpha_train * np.abs(code).sum(1)))
    return dict(err_ave=err, heldout_objective=obj,
                mean_active=float(res.n_active[res.status == "recovered"].mean()),
                certified=float(np.mean(res.status[res.status != "complete"] == "recovered")))


def run(quick=False):
    cfg = QUICK if quick else FULL
    k = cfg["k"]
    a_train, a_rec, a_src = alphas()
    poses, clips, data_path = load_cmu()
    is_val, held = split_clips(clips)
    X, _ = complete_pose_vectors(poses[~is_val])
    val = held_out_sample(poses[is_val], cfg["n_heldout"])
    mask = random_occlusion(len(val), 14, "mix", random_state=0)
    gt = pose_to_vector(val)
    n_batches = -(-len(X) // 512)
    out = dict(k=k, alpha_train=a_train, alpha_recover=a_rec, alpha_source=a_src,
               n_train=int(len(X)), n_train_clips=int(len(set(clips.tolist())) - len(held)),
               n_heldout_clips=len(held), n_heldout=int(len(val)), n_batches=n_batches,
               data=str(data_path), rows=[])
    log(f"fit: k={k}, {len(X)} training vectors, {n_batches} batches, alpha={a_train}")

    # the initial atoms OnlineDictionaryLearning.fit draws; SPAMS and sklearn get them too
    init = init_dictionary(X, k, np.random.SeedSequence([0, 0]))

    # --- sparseedm: warm the numba caches first (compile time is not fit time)
    OnlineDictionaryLearning(20, alpha=a_train, batch_size=64, random_state=0).fit(X[:256])
    t0 = time.perf_counter()
    odl = OnlineDictionaryLearning(k, alpha=a_train, batch_size=512, n_passes=1,
                                   random_state=0).fit(X)
    t_ours = time.perf_counter() - t0
    assert np.allclose(odl.components_.shape, init.shape)
    log(f"fit: sparseedm {t_ours:.1f} s ({odl.n_steps_} batches)")
    ours = odl.components_.copy()
    out["rows"].append(dict(name="sparseedm OnlineDictionaryLearning (numba, 2 threads)",
                            seconds=t_ours, batches=odl.n_steps_, partial=False,
                            **evaluate(ours, a_train, a_rec, val, mask, gt)))

    # --- SPAMS trainDL, same batches, same init, same objective
    try:
        import spams

        Xf = np.asfortranarray(X.T, dtype=np.float64)
        D0 = np.asfortranarray(init.T, dtype=np.float64)
        kw = dict(K=k, lambda1=a_train, mode=2, batchsize=512, numThreads=2,
                  posAlpha=False, verbose=False)
        # probe 2 batches first, so a pathological slowdown cannot eat the run
        t0 = time.perf_counter()
        spams.trainDL(Xf, D=np.asfortranarray(D0.copy()), iter=2, **kw)
        probe = (time.perf_counter() - t0) / 2 * n_batches
        if probe > cfg["spams_cap_s"]:
            log(f"fit: SPAMS would take ~{probe:.0f} s: not run in full")
            out["rows"].append(dict(name="SPAMS trainDL (mode=2, numThreads=2)",
                                    error=f"2-batch probe extrapolates to {probe:.0f} s "
                                          f"(> cap {cfg['spams_cap_s']:.0f} s); not run"))
        else:
            t0 = time.perf_counter()
            D = spams.trainDL(Xf, D=D0, iter=n_batches, **kw)
            t_spams = time.perf_counter() - t0
            comp, dropped, min_norm = _unit_rows(np.asarray(D).T)
            log(f"fit: SPAMS {t_spams:.1f} s")
            out["rows"].append(dict(name="SPAMS trainDL (mode=2, numThreads=2)",
                                    seconds=t_spams, batches=n_batches, partial=False,
                                    dropped_atoms=dropped, min_atom_norm=min_norm,
                                    **evaluate(comp, a_train, a_rec, val, mask, gt)))
    except ImportError as exc:
        out["rows"].append(dict(name="SPAMS trainDL", error=f"not importable: {exc}"))

    # --- sparseedm again with two passes: what its speed buys at SPAMS' time scale
    t0 = time.perf_counter()
    odl2 = OnlineDictionaryLearning(k, alpha=a_train, batch_size=512, n_passes=2,
                                    random_state=0).fit(X)
    t_two = time.perf_counter() - t0
    log(f"fit: sparseedm, 2 passes {t_two:.1f} s")
    out["rows"].append(dict(name="sparseedm OnlineDictionaryLearning, 2 passes",
                            seconds=t_two, batches=odl2.n_steps_, partial=False,
                            **evaluate(odl2.components_, a_train, a_rec, val, mask, gt)))

    # --- scikit-learn MiniBatchDictionaryLearning under a wall-clock cap
    from sklearn.decomposition import MiniBatchDictionaryLearning

    budget = cfg["sklearn_budget_s"]
    mbdl = MiniBatchDictionaryLearning(n_components=k, alpha=a_train, batch_size=512,
                                       dict_init=init, fit_algorithm="lars",
                                       random_state=0, transform_algorithm="lasso_lars")
    order = np.random.default_rng(0).permutation(len(X))
    t0 = time.perf_counter()
    done = 0
    for b in range(n_batches):
        mbdl.partial_fit(X[order[b * 512:(b + 1) * 512]])
        done += 1
        if time.perf_counter() - t0 > budget:
            break
    t_sk = time.perf_counter() - t0
    partial = done < n_batches
    comp, dropped, min_norm = _unit_rows(mbdl.components_)
    est = t_sk / done * n_batches
    log(f"fit: sklearn {done}/{n_batches} batches in {t_sk:.1f} s (full pass ~{est:.0f} s)")
    out["rows"].append(dict(name="scikit-learn MiniBatchDictionaryLearning (lars)",
                            seconds=est, measured_seconds=t_sk, batches=done, partial=partial,
                            dropped_atoms=dropped,
                            **evaluate(comp, a_train, a_rec, val, mask, gt)))
    out["components"] = ours
    return out


def render(res):
    from . import table

    rows = []
    base = res["rows"][0]["seconds"]
    for r in res["rows"]:
        if "error" in r:
            rows.append([r["name"], "-", "-", "-", "-", "-", r["error"]])
            continue
        if r["partial"]:
            t = f"~{r['seconds']:.0f} (extrapolated from {r['measured_seconds']:.0f} s)"
            note = (f"stopped after {r['batches']}/{res['n_batches']} batches (time cap); "
                    "error is of that partial dictionary")
        else:
            t = f"{r['seconds']:.1f}"
            note = f"{r['batches']} batches"
        if r.get("dropped_atoms"):
            note += f"; {r['dropped_atoms']} all-zero atoms dropped"
        rows.append([r["name"], t, r["seconds"] / base, r["err_ave"], r["heldout_objective"],
                     r["mean_active"], note])
    head = (f"k = {res['k']}, alpha_train = {res['alpha_train']:g}, alpha_recover = "
            f"{res['alpha_recover']:g} (from {res['alpha_source']}); {res['n_train']:,} training "
            f"vectors from {res['n_train_clips']} CMU clips, batch 512, one pass = "
            f"{res['n_batches']} mini-batches, identical initial atoms; held-out: "
            f"{res['n_heldout']:,} poses from {res['n_heldout_clips']} other clips, Mix occlusion "
            "(seed 0), `recover(solver=\"fast\")`.\n\n")
    return head + table(
        ["learner", "wall time (s)", "time / ours", "held-out Mix Err_ave (%)",
         "held-out lasso objective", "mean active atoms (recovery)", "note"], rows)


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true")
    args = ap.parse_args(argv)
    print(render(run(args.quick)))


if __name__ == "__main__":
    main()
