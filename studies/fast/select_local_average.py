"""The stacked mean's local Gaussian averaged over several of its settings.

The default path's stacked mean fills every occluded pose with the
conditional mean of its hidden joints under the Gaussian of the draws (the
file's poses and their mirror images) nearest it
(:func:`sparseedm.gaussian_fill.local_gaussian_fill`: 100 neighbours, 50
pseudo-draws of the file's Gaussian, ridge 0.01, chosen again on the filled
pose). A variant is the equal-weight mean of several such fills, one per
member of the product of its options (cheap model averaging, the variance of
one bandwidth's answer reduced):

* ``k=50,100,200,400``: neighbourhood sizes (``k=n/8``: the draws' number
  over 8, clipped to 50-400);
* ``prior=25,50,100``: the file Gaussian's weight, in pseudo-draws;
* ``ridge=0.003,0.01,...``: the covariance's ridge (one value: that setting
  alone);
* ``mirror=both``: the fills over the draws with and without their mirror
  images (``mirror=no``: without them alone);
* ``shipped``: the package's fill as it is.

e.g. ``"k=50,100,200,400 mirror=both"`` is the mean of eight fills.
``--screen``: the Gaussian's own fill (no path), paired against the shipped
one, per file (fast). End to end (the default): ``recover()``'s defaults with
the variant in place of ``local_gaussian_fill`` (the stacked mean, its
held-back weight and the probes alike) against the shipped defaults, II on the
same files. Files, seeds, scores, tables: ``select_local_align.py``'s.

    python studies/fast/select_local_average.py --screen --seeds 0,1,2 \\
        --out selection_local_average_screen.json
    python studies/fast/select_local_average.py --seeds 0,1,2 --variant "k=50,100,200" \\
        --out selection_local_average.json
    python studies/fast/select_local_average.py --screen --table selection_local_average_screen.json
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import sys
import time
from functools import partial
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

CACHE = Path("/tmp/photos_average/cache")
#: select_local_align.py's cache: its II answers are reused (the same files)
ALIGN_CACHE = Path("/tmp/photos_align/cache")

#: the screened variants (parsed by :func:`members`)
VARIANTS = ("shipped", "k=50", "k=200", "k=400", "k=50,100,200", "k=50,100,200,400",
            "k=100,200,400", "prior=25,50,100", "mirror=no", "mirror=both", "ridge=0.003",
            "ridge=0.03", "ridge=0.1", "ridge=0.003,0.01,0.03,0.1",
            "k=50,100,200,400 mirror=both", "k=50,100,200,400 prior=25,50,100")


def members(variant):
    """The keyword options (``neighbours``, ``prior``, ``ridge``, ``mirror``) of
    each fill of a variant's mean."""
    opts = {"k": ["100"], "prior": ["50"], "ridge": ["0.01"], "mirror": ["yes"]}
    if variant != "shipped":
        for word in variant.split():
            key, _, values = word.partition("=")
            opts[key] = ["yes", "no"] if values == "both" else values.split(",")
    return [{"neighbours": k if k.startswith("n/") else int(k), "prior": float(p), "ridge": float(r), "mirror": m == "yes"}
            for k, p, r, m in itertools.product(opts["k"], opts["prior"], opts["ridge"],
                                                 opts["mirror"])]


def average_fill(train, poses, missing, *, variant="shipped"):
    """local_gaussian_fill's signature: the mean of the variant's fills (``mirror``
    False: over the first half of `train`, the draws without their mirror images
    as :func:`sparseedm.file_atoms.mirror_images` lays them out)."""
    from sparseedm.gaussian_fill import local_gaussian_fill

    if variant == "shipped":
        return local_gaussian_fill(train, poses, missing)
    fills = []
    for m in members(variant):
        draws = train if m.pop("mirror") else train[:len(train) // 2]
        if isinstance(m["neighbours"], str):  # n/D: a share of the draws
            m["neighbours"] = int(np.clip(len(draws) // int(m["neighbours"][2:]), 50, 400))
        fills.append(local_gaussian_fill(draws, poses, missing, **m))
    return np.mean(fills, axis=0)


@contextlib.contextmanager
def patched(variant):
    """recover()'s defaults with the variant in place of local_gaussian_fill."""
    import sparseedm.exemplars as ex

    kept = ex.local_gaussian_fill
    if variant != "shipped":
        ex.local_gaussian_fill = partial(average_fill, variant=variant)
    try:
        yield
    finally:
        ex.local_gaussian_fill = kept


def _shipped(name, given, missing, photo, kw):
    """(answers, seconds, weight) of the shipped defaults and II (cached; II
    taken from select_local_align.py's cache when there)."""
    import sparseedm
    from studies.fast.select_local_align import _key
    from studies.fast.select_local_gaussian import _weight
    from studies.fast.select_photo_atoms import iterative

    occ = missing.any(axis=1)
    cache = CACHE / f"{_key(name)}.npz"
    if cache.exists():
        with np.load(cache) as z:
            return ({k: z[k] for k in z.files if k not in ("secs", "weights")},
                    dict(zip(("shipped", "iterative"), z["secs"].tolist())), float(z["weights"]))
    t0 = time.perf_counter()
    res = sparseedm.recover(given, missing, n_jobs=1, **kw)
    got, secs = {"shipped": res.poses[occ]}, {"shipped": round(time.perf_counter() - t0, 2),
                                                "iterative": np.nan}
    old = ALIGN_CACHE / f"{_key(name)}.npz"
    if photo and old.exists():
        with np.load(old) as z:
            got["iterative"], secs["iterative"] = z["iterative"], float(z["secs"][1])
    elif photo:
        t0 = time.perf_counter()
        got["iterative"] = iterative(given, missing)[occ]
        secs["iterative"] = round(time.perf_counter() - t0, 2)
    CACHE.mkdir(parents=True, exist_ok=True)
    np.savez(cache, **got, secs=[secs["shipped"], secs["iterative"]], weights=_weight(res))
    return got, secs, _weight(res)


def measure(name, truth, missing, photo, kw, variant):
    """One file end to end: per-pose errors of the shipped defaults, II (photos)
    and the variant; weights; seconds."""
    import sparseedm
    from studies.fast.select_local_gaussian import _weight
    from studies.fast.select_photo_blend import per_pose

    occ = missing.any(axis=1)
    given = np.where(missing[..., None], np.nan, truth)
    got, secs, w = _shipped(name, given, missing, photo, kw)
    t0 = time.perf_counter()
    with patched(variant):
        res = sparseedm.recover(given, missing, n_jobs=1, **kw)
    secs["variant"] = round(time.perf_counter() - t0, 2)
    got["variant"] = res.poses[occ]
    weights = {"shipped": w, "variant": _weight(res)}
    return secs, weights, {k: per_pose(v, truth[occ], missing[occ]) for k, v in got.items()}


def main(argv=None):
    from studies.fast.select_local_align import options, run, screen

    ap = options(argparse.ArgumentParser(description=__doc__.splitlines()[0]),
                 ";".join(VARIANTS), "k=50,100,200")
    ap.add_argument("--out", type=Path, default=Path("local_average.json"))
    run(ap.parse_args(argv), partial(screen, fill=lambda draws, poses, missing, variant:
                                     average_fill(draws, poses, missing, variant=variant)),
        measure, sep=";")


if __name__ == "__main__":
    main()
