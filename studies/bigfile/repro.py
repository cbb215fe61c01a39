"""Big files of near-copies: the default path's time and hidden-joint error.

``python -m studies.bigfile.repro SOURCE N [spacing=S] [seed=K] [n_jobs=J]
[--profile]`` (other ``key=value`` pairs go to ``recover``): N poses
resampled from the validation split's fully annotated poses of a real2d
SOURCE (mpii or bonn) with 0.5 px noise (N = 0: those poses once each, as
they are), each hidden by its own source pose's visibility flags; or SOURCE
``bandai``: the frontier's file of N poses (Mix masks); ``cmu``: the
frontier's video file of N frames (CMU clips, hidden runs), without tracks.
"""
from __future__ import annotations

import argparse
import time
import warnings

import numpy as np


def real_file(source, n, seed=0):
    from benchmarks import real2d
    rs = real2d.load(source)
    rs = rs.take((real2d.split(rs) == "val") & rs.annotated.all(axis=1))
    rng = np.random.default_rng(seed)
    pick = rng.integers(0, len(rs), n) if n else np.arange(len(rs))
    P = rs.poses[pick] + (rng.normal(scale=0.5, size=(n, 14, 2)) if n else 0)
    mask = ~rs.visible[pick]
    mask[mask.sum(axis=1) > 10] = False  # too few seen: treat as complete
    return P, mask, len(rs)


def mocap_file(source, n):
    from benchmarks import CMU_RAW
    from benchmarks.default_path import load_bandai, make_file
    from benchmarks.temporal import build_video
    if source == "cmu":  # the frontier's video file, its frames given without tracks
        _, mask, tracks, _, P = build_video(CMU_RAW.parent, n, return_truth=True)
        return P, mask, len(np.unique(tracks))
    pool, _ = load_bandai()
    P, mask = make_file(pool, n)
    return P, mask, len(pool)


def hidden_error(out, truth, mask):
    from sparseedm.normalize import rms_radius
    size = rms_radius(truth, np.zeros(truth.shape[:2], bool))[1]
    d = np.linalg.norm(out - truth, axis=-1)
    d = np.where(mask, d, np.nan)
    rows = mask.any(axis=1)
    return float(np.nanmean(np.nanmean(d[rows], axis=1) / size[rows] * 100))


def main(argv=None):
    import sparseedm
    import sparseedm.file_atoms
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("source", choices=("mpii", "bonn", "bandai", "cmu"))
    ap.add_argument("n", type=int, help="poses (frames for cmu); 0: the real poses once each")
    ap.add_argument("options", nargs="*", metavar="KEY=VALUE",
                    help="spacing=S, seed=K, n_jobs=J; others go to recover()")
    ap.add_argument("--profile", action="store_true", help="print a cProfile of recover()")
    a = ap.parse_args(argv)
    source, n = a.source, a.n
    P, mask, pool = (mocap_file if source in ("bandai", "cmu") else real_file)(source, n)
    X = np.where(mask[..., None], np.nan, P)
    print(f"{source}: {len(P)} poses from {pool}, {int((~mask.any(1)).sum())} complete, "
          f"{int(mask.any(1).sum())} occluded", flush=True)
    kw = {}
    for option in a.options:
        if "=" in option:
            k, v = option.split("=", 1)
            kw[k] = v
    # spacing=0: the atoms as before near-copies were merged; seed=K: another sample
    defaults = sparseedm.file_atoms.file_dictionary.__kwdefaults__
    if "spacing" in kw:
        defaults["spacing"] = float(kw.pop("spacing"))
    if "seed" in kw:
        defaults["random_state"] = int(kw.pop("seed"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        t0 = time.perf_counter()
        if a.profile:
            import cProfile
            import pstats
            pr = cProfile.Profile()
            pr.enable()
        res = sparseedm.recover(X, n_jobs=int(kw.pop("n_jobs", 2)), **kw)
        t = time.perf_counter() - t0
        if a.profile:
            pr.disable()
            pstats.Stats(pr).sort_stats("cumulative").print_stats(35)
    print(f"{t:.1f} s, {len(P) / t:,.0f} poses/s, hidden-joint error "
          f"{hidden_error(res.poses, P, mask):.3f} % of pose size; "
          f"path {res.adaptation.summary().get('path') if res.adaptation else None}")


if __name__ == "__main__":
    main()
