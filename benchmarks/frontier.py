"""``python -m benchmarks.frontier [--quick] [--write-docs] [--plot-only]``: the
accuracy-speed frontier, every sparseedm setting against its peers, one run.

Files (what users hand to ``recover``, NaN at the hidden joints):

* the default-path benchmark's pose files (:mod:`benchmarks.default_path`):
  6,000 and 30,000 Bandai-Namco-1 poses (no shipped dictionary has seen them;
  CC BY-NC 4.0, used here for evaluation only), half complete and half under
  the evaluation protocol's Mix masks (1-3 joints);
* a 10,000-frame video file (:func:`benchmarks.temporal.build_video`: CMU
  clips through one fixed camera each, runs of 3-90 frames hidden on 1-3
  joints per clip).

Rows: ``recover(adapt=False)``, ``recover(preset="fast")``, ``recover()``
with its defaults and ``recover(ensemble=3)`` (the 6,000-pose file only: it
is three times the defaults' work); scikit-learn's ``IterativeImputer(max_iter=10,
tol=0)`` and ``KNNImputer()`` fitted on and filling the whole file
(``fit_transform`` on the pixel coordinates, as a user runs them); on the
video also the gap fillers of :mod:`sparseedm.temporal.fillers` per track
(linear, Akima, the Kalman smoother) and the temporal model
(``recover(frames=...)``, defaults). sparseedm calls get ``n_jobs=2``; JIT
caches are warmed first. On the 6,000-pose file the fast preset and
IterativeImputer on one BLAS thread run ``--repeats`` times (default 3; the
median is reported); every other row runs once. IterativeImputer also runs on one BLAS thread, the
only way it runs on the larger files: on a loaded machine its two spinning
BLAS threads cost it up to ten times its time (same answers), and the
comparison should not hang on that.

Error: Err_ave (%) of the returned poses' EDMs against the truth, over the
poses with a hidden joint (the same number for every method: what a user
gets back; a pose a method leaves unfilled or refuses counts as missing, and
``unfilled`` says how many). Speed: poses (frames) per second of wall time,
fitting included.

``--write-docs`` writes ``results-frontier.json`` (rendered by the docs'
results pages) and the plot ``docs/frontier.png``; ``--plot-only`` redraws
the plot from that JSON.
"""

from __future__ import annotations

import argparse
import json
import time
import warnings
from pathlib import Path

import numpy as np

from . import CMU_RAW, log, loadavg, machine, versions
from sparseedm._atomic import save_json

HERE = Path(__file__).resolve().parent
RESULTS = HERE / "results-frontier.json"
PLOT = HERE.parent / "docs" / "frontier.png"
SPARSE = {"recover(adapt=False)": dict(adapt=False),
          "recover(preset='fast')": dict(preset="fast"),
          "recover() defaults": {},
          "recover(ensemble=3)": dict(ensemble=3)}
REPEATED = ("recover(preset='fast')", "IterativeImputer, 1 BLAS thread",
            "recover(preset='fast'), lasso on working sets")
#: rows run only when named by --only: the fast preset's atoms coded by the exact
#: lasso (its former coder: working sets of the fast solver) beside its local ridge
EXTRA = {"recover(preset='fast'), lasso on working sets": dict(preset="fast", solver="lasso")}


def pose_error(filled, truth, rows):
    """Mean Err_ave (%) of `rows`' EDMs of `filled` against `truth`, and how many
    of them came back with a non-finite joint (left out of the mean)."""
    from sparseedm.edm import pose_to_vector
    from sparseedm.metrics import err_ave

    ok = np.isfinite(filled[rows]).all(axis=(1, 2))
    e = err_ave(pose_to_vector(filled[rows][ok]), pose_to_vector(truth[rows][ok]))
    return float(np.mean(e)), int((~ok).sum())


def _imputer(kind, blas_threads=None):
    from sklearn.experimental import enable_iterative_imputer  # noqa: F401
    from sklearn.impute import IterativeImputer, KNNImputer
    from threadpoolctl import threadpool_limits

    def fill(X, mask=None, **_):
        imp = IterativeImputer(max_iter=10, tol=0) if kind == "iterative" else KNNImputer()
        with warnings.catch_warnings(), threadpool_limits(blas_threads, user_api="blas"):
            warnings.simplefilter("ignore")
            out = imp.fit_transform(X.reshape(len(X), -1)).reshape(X.shape)
        return np.where(np.isnan(X), out, X)
    return fill


def _peers(default_threads=True):
    """The imputers as a user runs them (IterativeImputer's BLAS threads as they are,
    with `default_threads`) and IterativeImputer on one BLAS thread (on a loaded
    machine its spinning BLAS threads can cost it many times its time)."""
    out = {"IterativeImputer": _imputer("iterative")} if default_threads else {}
    return dict(out, **{"IterativeImputer, 1 BLAS thread": _imputer("iterative", 1),
                        "KNNImputer": _imputer("knn")})


def _sparse(kw):
    import sparseedm
    from sparseedm.solvers.fast import FastSolver

    def fill(X, mask, **more):
        args = (dict(kw, solver=FastSolver(working_set=True)) if kw.get("solver") == "lasso"
                else kw)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return sparseedm.recover(X, mask, n_jobs=2, **args, **more).poses
    return fill


def _timed(fill, X, mask, truth, rows, repeats, **more):
    """Median seconds of `repeats` runs, and the error of the last."""
    secs = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fill(X, mask, **more)
        secs.append(time.perf_counter() - t0)
    err, unfilled = pose_error(out, truth, rows)
    s = float(np.median(secs))
    return {"seconds": s, "poses_per_s": len(X) / s, "err": err, "unfilled": unfilled,
            "runs": len(secs)}


def pose_file(pool, n, repeats, with_ensemble, only=None):
    from .default_path import make_file

    P, mask = make_file(pool, n)
    X = np.where(mask[..., None], np.nan, P)
    rows = np.flatnonzero(mask.any(axis=1))
    methods = _peers(default_threads=n <= 6000)
    methods.update({k: _sparse(v) for k, v in SPARSE.items()
                    if with_ensemble or "ensemble" not in k})
    if only:
        methods.update({k: _sparse(v) for k, v in EXTRA.items()})
        methods = {k: f for k, f in methods.items() if k in only}
    out = []
    for name, fill in methods.items():
        log(f"  {n:,} poses: {name}")
        r = _timed(fill, X, mask, P, rows, repeats if name in REPEATED else 1)
        out.append({"method": name, **r})
        log(f"    {r['seconds']:.2f} s, {r['poses_per_s']:,.0f} poses/s, Err_ave {r['err']:.3f} %")
    return out


def _per_track(fill):
    def run(X, mask, *, tracks, frames):
        out = X.copy()
        for clip in np.unique(tracks):
            r = tracks == clip
            out[r] = fill(X[r], mask[r], frames[r])
        return out
    return run


def video_file(n_frames, repeats):
    from sparseedm.temporal.fillers import fill_akima, fill_kalman, fill_linear

    from .temporal import build_video

    X, mask, tracks, frames, truth = build_video(CMU_RAW.parent, n_frames, return_truth=True)
    rows = np.flatnonzero(mask.any(axis=1))
    methods = {
        "linear per track": _per_track(fill_linear),
        "Akima per track": _per_track(fill_akima),
        "Kalman smoother per track": _per_track(fill_kalman),
        **_peers(default_threads=False),
        "recover(adapt=False)": _sparse(dict(adapt=False)),
        "recover(preset='fast')": _sparse(dict(preset="fast")),
        "recover(frames=...) defaults": _sparse({}),
    }
    out = []
    for name, fill in methods.items():
        log(f"  video, {len(X):,} frames: {name}")
        more = dict(tracks=tracks, frames=frames) if ("track" in name or "frames=" in name) \
            else {}
        r = _timed(fill, X, mask, truth, rows, repeats if name in REPEATED else 1, **more)
        out.append({"method": name, **r})
        log(f"    {r['seconds']:.2f} s, {r['poses_per_s']:,.0f} frames/s, Err_ave {r['err']:.3f} %")
    return out


def run(quick=False, repeats=3, done=None, only=None):
    import sparseedm
    from sparseedm.adaptation import run_adaptation

    from .default_path import load_bandai, make_file

    pool, _ = load_bandai()
    base = sparseedm.load_dictionary()
    with warnings.catch_warnings():  # the JIT caches, out of the timings
        warnings.simplefilter("ignore")
        run_adaptation(base, pool[:300], min_poses=1, passes=1)
        P, mask = make_file(pool, 400, seed=1)
        sparseedm.recover(np.where(mask[..., None], np.nan, P), mask, adapt=False, n_jobs=2)
        sparseedm.recover(np.where(mask[..., None], np.nan, P), mask, preset="fast", n_jobs=2)
    files = {}
    for n in ((1200,) if quick else (6000, 30000)):
        files[f"{n:,} poses (Bandai-Namco-1, half under Mix)"] = pose_file(
            pool, n, repeats if n <= 6000 else 1, with_ensemble=n <= 6000, only=only)
        if done is not None:
            done(files)
    if only:
        return files
    n_frames = 2000 if quick else 10000
    files[f"{n_frames:,}-frame video (CMU clips)"] = video_file(n_frames, 1)
    return files


def plot(results, path=PLOT):
    """Error against poses/s, one panel per file (matplotlib, the plot extra)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    files = results["files"]
    from matplotlib.ticker import NullFormatter

    fig, axes = plt.subplots(1, len(files), figsize=(5.5 * len(files), 4.6), squeeze=False)
    for ax, (name, rows) in zip(axes[0], files.items()):
        for i, r in enumerate(sorted(rows, key=lambda r: r["poses_per_s"])):
            ours = r["method"].startswith("recover")
            ax.scatter(r["poses_per_s"], r["err"], marker="o" if ours else "s",
                       color="C0" if ours else "C3")
            ax.annotate(r["method"], (r["poses_per_s"], r["err"]), fontsize=6.5,
                        xytext=(4, (4, -10, 14)[i % 3]), textcoords="offset points")
        ax.set_xscale("log")
        ax.xaxis.set_minor_formatter(NullFormatter())
        ax.set_xlabel("poses (frames) per second")
        ax.set_ylabel("Err_ave of the occluded poses (%)")
        ax.set_title(name, fontsize=9)
        ax.grid(alpha=0.3)
    m = results["meta"]
    fig.suptitle(f"sparseedm (blue) and peers (red), {m['date']}, {m['machine']['cores']} "
                 f"cores, load {m['loadavg_start'][0]:.1f}", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path


def main(argv=None):
    ap = argparse.ArgumentParser(prog="python -m benchmarks.frontier",
                                 description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true",
                    help="1,200 poses and a 2,000-frame video, no ensemble: a smoke test")
    ap.add_argument("--repeats", type=int, default=3,
                    help="runs of the imputer and the fast preset on the 6,000-pose file "
                    "(the median; default 3)")
    ap.add_argument("--write-docs", action="store_true",
                    help="write results-frontier.json and docs/frontier.png")
    ap.add_argument("--only", nargs="+", metavar="ROW",
                    help="run only these rows, on the pose files (no video; never "
                    "written by --write-docs); besides the frontier's rows: "
                    + ", ".join(f'"{k}"' for k in EXTRA))
    ap.add_argument("--plot-only", action="store_true",
                    help="redraw docs/frontier.png from results-frontier.json")
    args = ap.parse_args(argv)
    if args.plot_only:
        print(plot(json.loads(RESULTS.read_text())))
        return
    meta = dict(date=time.strftime("%Y-%m-%d %H:%M %Z"), machine=machine(),
                versions=versions(), loadavg_start=loadavg(), quick=args.quick,
                repeats=args.repeats)
    write = args.write_docs and not args.quick and not args.only
    meta["only"] = args.only

    def done(files, final=False):
        meta["loadavg_end"] = loadavg()
        if not final:
            meta["partial"] = True  # the files so far (a run cut short keeps them)
        else:
            meta.pop("partial", None)
        if write:
            save_json(RESULTS, dict(meta=meta, files=files), indent=1, default=str)

    files = run(args.quick, args.repeats, done, args.only)
    done(files, final=True)
    print(json.dumps(files, indent=1))
    if write:
        print(plot(dict(meta=meta, files=files)))


if __name__ == "__main__":
    main()
