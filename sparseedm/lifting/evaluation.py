"""The paper's application table: how recovered 2D poses serve 3D lifting.

Guo & Dai's Table 1 / lower Table 2 measure recovery *inside* DMR's pipeline.
:func:`evaluate_lifting` runs that protocol on held-out poses with known 3D
(``poses3d`` and cameras, as ``sparseedm dataset build`` writes them), with the
same seeded occlusions (1, 2, 3 joints and Mix) for every pipeline:

``complete``        the lifter on the complete 2D pose (the reference row);
``as-is average`` / ``as-is zero``
                    the lifter on the occluded pose's whole 2D EDM in that
                    representation (the paper's "baseline on occluded input");
``applyspar``       sparse recovery (:func:`sparseedm.recover`), then the lifter;
``knn`` / ``iterative`` / ``nearest`` (+ lifter)
                    a 2D imputer of :mod:`sparseedm.baselines`, then the lifter;
``joint``           dictionary lifter only: one lasso on the observed 2D
                    entries, 3D read from the coupled atoms (recovery and
                    lifting in one step).

``applyzero`` / ``applyave``
                    FConv recovery (``recover(..., method="fconv")`` with a
                    ``sparseedm fit-cnn`` model trained on 'zero' / 'average'
                    input), then the lifter;
``zero+basl`` / ``ave+basl``
                    no recovery: a lifter retrained end to end on occluded
                    'zero' / 'average' input (e.g. ``fit-lifter --method fconv
                    --occluded 1-3``) on the occluded pose as is; listed under
                    that lifter's method.

Each pipeline is run for every lifter given (``dictionary`` and, if given,
``mlp`` = DMR's FConn and ``fconv`` = DMR's FConv). The FConv rows need the
torch extra and their models; without them they are skipped with a note.

Per row: 3D-EDM Err_ave (per cent, one least-squares scale per pose, see
:mod:`.metrics`), PA-MPJPE, N-MPJPE and MPJPE (mm; MPJPE at the lifter's size
prior), how often the chosen depth reflection is the right one and how often
it was ambiguous, and poses per second for the whole pipeline.
"""

from __future__ import annotations

import importlib.util
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .. import _progress
from .._atomic import atomic_path, json_text
from ..baselines import fit_baseline
from ..exceptions import SparseEDMError
from ..fconv.model import load_model
from ..metrics import random_occlusion
from ..normalize import represent
from ..recovery import recover
from .base import training_pairs
from .lift import poses_from_vectors
from .metrics import err_ave_3d, mpjpe, pa_mpjpe, pelvis

__all__ = ["evaluate_lifting", "LiftReport", "COLUMNS"]

COLUMNS = ("lifter", "pipeline", "count", "n_poses", "n_failed", "err3d", "pa_mpjpe", "n_mpjpe", "mpjpe",
           "reflection_ok", "ambiguous", "poses_per_s")
IMPUTERS = ("knn", "iterative", "nearest")
#: FConv recovery then lifting: pipeline -> representation of the fit-cnn model
APPLY_FCONV = {"applyzero": "zero", "applyave": "average"}
#: lifters retrained end to end on occluded input: pipeline -> representation
RETRAINED = {"zero+basl": "zero", "ave+basl": "average"}


@dataclass
class LiftReport:
    """Rows of the application table, per-action Mix errors, examples for figures.

    Parameters
    ----------
    rows : list of dict
        One row per lifter, pipeline and occlusion count, with the keys of
        :data:`COLUMNS` (errors are means over the poses that were lifted).
    per_action : list of dict
        Mix-occlusion 3D-EDM error per action label (``label``, ``lifter``,
        ``pipeline``, ``n_poses``, ``err3d``); empty without labels.
    examples : dict
        A few poses for the figure: ``truth``, ``lifted``, ``missing`` and
        ``titles``; empty when the ``joint`` pipeline was not run.
    settings : dict
        What was run: number of poses, data name, seed, counts, pipelines,
        lifters and the FConv models used.
    notes : list of str, optional
        Pipelines skipped and poses that could not be lifted, in words.
    """

    rows: list
    per_action: list
    examples: dict
    settings: dict
    notes: list = field(default_factory=list)

    def table(self, **where):
        return [r for r in self.rows if all(str(r[k]) == str(v) for k, v in where.items())]

    def to_markdown(self):
        s = self.settings
        out = ["# sparseedm lifting evaluation (the paper's application table)", "",
               f"Test poses: {s['n_poses']} from {s['data']}; occlusion seed {s['seed']}; "
               f"lifters: {', '.join(f'{k} = {v}' for k, v in s['lifters'].items())}.", "",
               "err3d: 3D-EDM Err_ave in per cent after one least-squares scale per pose; "
               "PA-MPJPE / N-MPJPE / MPJPE in mm (similarity / scale / none beyond the "
               "pelvis; MPJPE at the lifter's size prior); reflection_ok: chosen depth "
               "reflection closer to the truth than its mirror; ambiguous: chirality "
               "margin < 1.", ""]
        counts = list(dict.fromkeys(str(r["count"]) for r in self.rows))
        out.append("| lifter | pipeline | " + " | ".join(f"err3d {c}" for c in counts)
                   + " | PA-MPJPE Mix | N-MPJPE Mix | MPJPE Mix | reflection ok Mix "
                   "| poses/s Mix |")
        out.append("|---" * (len(counts) + 7) + "|")
        keys = list(dict.fromkeys((r["lifter"], r["pipeline"]) for r in self.rows))
        nan = float("nan")
        for lf, pl in keys:
            rr = {str(r["count"]): r for r in self.table(lifter=lf, pipeline=pl)}
            mix = rr.get("mix") or rr.get("none") or {}
            out.append(f"| {lf} | {pl} | " + " | ".join(
                f"{rr[c]['err3d']:.2f}" if c in rr else "" for c in counts)
                + f" | {mix.get('pa_mpjpe', nan):.1f} | {mix.get('n_mpjpe', nan):.1f} | "
                  f"{mix.get('mpjpe', nan):.1f} | {mix.get('reflection_ok', nan):.2f} | "
                  f"{mix.get('poses_per_s', 0):.0f} |")
        if self.per_action:
            out += ["", "## Per action (Mix err3d)", "", "| label | lifter | pipeline | n | err3d |",
                    "|---|---|---|---|---|"]
            out += [f"| {r['label']} | {r['lifter']} | {r['pipeline']} | {r['n_poses']} | "
                    f"{r['err3d']:.2f} |" for r in self.per_action]
        out += [""] + [f"- {n}" for n in self.notes]
        return "\n".join(out) + "\n"

    def write(self, directory, figures=True):
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        written = []
        for name, text in (("lift_report.md", self.to_markdown()),
                           ("lift_results.json", json_text(
                               {"settings": self.settings, "rows": self.rows,
                                "per_action": self.per_action, "notes": self.notes},
                               indent=1, default=str))):
            with atomic_path(directory / name) as tmp:
                Path(tmp).write_text(text)
            written.append(directory / name)
        if figures and self.examples:
            from ..plotting import have_matplotlib

            if have_matplotlib():
                from .plotting import plot_poses3d

                ex = self.examples
                written.append(plot_poses3d(ex["truth"], ex["lifted"], directory / "lift_poses.png",
                                            titles=ex["titles"], missing=ex["missing"]))
        return written


def _lift_rows(lifter, X2, poses2d, predict_missing, geometry_missing, n_jobs):
    """Lift given 2D vectors; returns (poses3d, vectors3d, margin, ok)."""
    Y, info = lifter.predict(X2, predict_missing, n_jobs=n_jobs)
    ok = (info["status"] != "failed") & np.isfinite(Y).all(axis=1)
    P = np.full(poses2d.shape[:2] + (3,), np.nan)
    margin = np.full(len(Y), np.nan)
    if ok.any():
        P[ok], margin[ok], _ = poses_from_vectors(lifter, Y[ok], poses2d[ok],
                                                  geometry_missing[ok])
    return P, Y, margin, ok


def _score(P, Y, margin, truth_vec, truth_cam):
    ok = np.isfinite(P).all(axis=(1, 2))
    e3 = np.full(len(P), np.nan)
    e3[ok] = err_ave_3d(Y[ok], truth_vec[ok])
    pa = np.full(len(P), np.nan)
    pa[ok] = pa_mpjpe(P[ok], truth_cam[ok])
    t = truth_cam - pelvis(truth_cam)[:, None, :]
    mirror = P * np.array([1.0, 1.0, -1.0])
    mirror = mirror - pelvis(mirror)[:, None, :]
    d_keep = np.linalg.norm(P - t, axis=-1).mean(axis=1)
    d_flip = np.linalg.norm(mirror - t, axis=-1).mean(axis=1)
    return {"err3d": e3, "pa_mpjpe": pa,
            "n_mpjpe": np.where(ok, mpjpe(np.nan_to_num(P), truth_cam, align="scale"), np.nan),
            "mpjpe": np.where(ok, mpjpe(np.nan_to_num(P), truth_cam), np.nan),
            "reflection_ok": np.where(ok, d_keep <= d_flip, np.nan),
            "ambiguous": np.where(ok, margin < 1, np.nan)}


def evaluate_lifting(lifters, test, *, dictionary=None, train_poses2d=None,
                     counts=(1, 2, 3, "mix"), pipelines=None, max_poses=None, seed=0,
                     n_jobs=1, max_train=20000, data_name="test data", fconv_models=None,
                     retrained=None):
    """Run the application table.

    Parameters
    ----------
    lifters : dict name -> Lifter
        E.g. ``{"dictionary": ..., "mlp": ...}``.
    test : dict
        ``poses2d``, ``poses3d``, ``camera_R``, ``camera_t``, ``camera_f`` and
        optionally ``labels`` (a dataset as :func:`sparseedm.dataset.load_dataset`
        returns it).
    dictionary : Dictionary or name, optional
        For ``applyspar`` (default: the shipped 2D dictionary).
    train_poses2d : (n, N, 2), optional
        For the imputer pipelines (skipped without it).
    counts : iterable of {1, 2, 3, ..., "mix"}, default (1, 2, 3, "mix")
        Occluded joints per pose, one seeded occlusion per count shared by
        every pipeline (``"mix"``: 1, 2 or 3 per pose).
    pipelines : iterable of str, optional
        Default: all of complete, as-is average, as-is zero, applyspar, the
        imputers (with training poses), joint, and the FConv rows whose
        models are given.
    max_poses : int, optional
        Evaluate a seeded sample of this many test poses; default all.
    seed : int, default 0
        Seed of the pose sample, the occlusions, the imputers' training
        sample and the example poses.
    n_jobs : int, default 1
        Workers of the lifters' predictions and of the sparse recovery.
    max_train : int, default 20000
        The imputers are fitted on a seeded sample of at most this many
        training poses.
    data_name : str, default "test data"
        Name of the test data, for the report.
    fconv_models : dict, optional
        ``{"zero": model, "average": model}`` (FConvModel or path; either
        key may be absent): the FConv recovery models of ``applyzero`` /
        ``applyave``.
    retrained : dict, optional
        ``{"zero": lifter, "average": lifter}``: lifters retrained on
        occluded input in that representation, for ``zero+basl`` / ``ave+basl``.

    Returns
    -------
    LiftReport
        The table's rows, per-action errors, example poses, the settings and
        notes on what was skipped.
    """
    rng = np.random.default_rng(seed)
    n_all = len(test["poses2d"])
    idx = np.arange(n_all)
    if max_poses and max_poses < n_all:
        idx = np.sort(rng.choice(n_all, max_poses, replace=False))
    poses2d = np.asarray(test["poses2d"], float)[idx]
    _, _, truth_vec, truth_cam = training_pairs(
        poses2d, test["poses3d"][idx], test["camera_R"][idx], test["camera_t"][idx],
        test["camera_f"][idx])
    labels = np.asarray(test["labels"])[idx] if "labels" in test else None
    n, N, _ = poses2d.shape
    notes = []
    all_pipes = ["complete", "as-is average", "as-is zero", "applyspar", *IMPUTERS, "joint",
                 *APPLY_FCONV, *RETRAINED]
    pipelines = list(pipelines or all_pipes)
    fconv_models, retrained = dict(fconv_models or {}), dict(retrained or {})
    lifters, pipelines = _torch_rows(lifters, pipelines, fconv_models, retrained, notes)
    pipelines, imputers, more = _fit_imputers(pipelines, train_poses2d, max_train, seed)
    notes += more
    rows, per_action, examples = [], [], {}
    none_mask = np.zeros((n, N), bool)
    masks = {c: random_occlusion(n, N, c, random_state=np.random.default_rng([seed, i]))
             for i, c in enumerate(counts)}
    jobs = [(lname, lifter, pipe) for lname, lifter in lifters.items() for pipe in pipelines
            if pipe not in RETRAINED and (pipe != "joint" or lifter.codes_observed_only)]
    jobs += [(lf.method, lf, pipe) for pipe, rep in RETRAINED.items()
             if pipe in pipelines for lf in [retrained[rep]]]
    for lname, lifter, pipe in _progress.steps(jobs, f"lifting {n:,} test poses through "
                                               f"{len(jobs)} lifter/pipeline pairs",
                                               total=len(jobs), unit="pipeline"):
        _progress.say(f"evaluating lifter {lname}, pipeline {pipe}")
        for count in (["none"] if pipe == "complete" else counts):
            mask = none_mask if pipe == "complete" else masks[count]
            t0 = time.perf_counter()
            P, Y, margin = _lift_pipeline(pipe, lifter, poses2d, mask, dictionary,
                                          fconv_models, imputers, n_jobs)
            sec = time.perf_counter() - t0
            sc = _score(P, Y, margin, truth_vec, truth_cam)
            # poses without a lifted answer (a recovery that failed, a refused
            # input) are left out of the means: counted, and said in the notes
            n_failed = int((~np.isfinite(P).all(axis=(1, 2))).sum())
            if n_failed:
                notes.append(f"{lname}, {pipe}, {count} occluded: {n_failed} of {n} poses "
                             "could not be lifted; the means are over the others")
            row = {"lifter": lname, "pipeline": pipe, "count": count, "n_poses": n,
                   "n_failed": n_failed}
            row.update({k: float(np.nanmean(v)) for k, v in sc.items()})
            row["poses_per_s"] = n / sec
            rows.append(row)
            if labels is not None and count == "mix":
                for lab in np.unique(labels):
                    sel = labels == lab
                    per_action.append({"label": str(lab), "lifter": lname, "pipeline": pipe,
                                       "n_poses": int(sel.sum()),
                                       "err3d": float(np.nanmean(sc["err3d"][sel]))})
            if pipe == "joint" and count == "mix" and not examples:
                pick = np.random.default_rng(seed).choice(n, min(4, n), replace=False)
                examples = {"truth": truth_cam[pick] - pelvis(truth_cam[pick])[:, None],
                            "lifted": P[pick], "missing": mask[pick],
                            "titles": [f"{int(mask[i].sum())} occluded, err3d "
                                       f"{sc['err3d'][i]:.1f}%" for i in pick]}
    settings = {"n_poses": int(n), "data": data_name, "seed": seed,
                "counts": [str(c) for c in counts], "pipelines": pipelines,
                "lifters": {k: v.method for k, v in lifters.items()},
                "retrained": {k: v.method for k, v in retrained.items()},
                "fconv_recovery": sorted(fconv_models)}
    return LiftReport(rows, per_action, examples, settings, notes)


def _fit_imputers(pipelines, train_poses2d, max_train, seed):
    """The pipelines left (the imputers' dropped without training poses), the
    imputers fitted on the training poses, and a note when they were dropped."""
    imputers, notes = {}, []
    if any(p in IMPUTERS for p in pipelines):
        if train_poses2d is None:
            notes.append("no training poses: the imputer pipelines were skipped")
            pipelines = [p for p in pipelines if p not in IMPUTERS]
        else:
            for p in pipelines:
                if p in IMPUTERS:
                    _progress.say(f"fitting the {p} imputer on at most {max_train:,} of "
                                  f"{len(train_poses2d):,} training poses (seeded sample)")
                    imputers[p] = fit_baseline(p, train_poses2d, max_train=max_train,
                                               random_state=seed)
    return pipelines, imputers, notes


def _lift_pipeline(pipe, lifter, poses2d, mask, dictionary, fconv_models, imputers, n_jobs):
    """``(poses3d, vectors3d, chirality_margin)`` of one pipeline: the poses
    occluded by `mask`, recovered (or not) as `pipe` says, then lifted."""
    none_mask = np.zeros(mask.shape, bool)
    if pipe in ("complete", "joint"):
        X2, _, _ = represent(poses2d, mask, "average")
        P, Y, margin, _ = _lift_rows(lifter, X2, poses2d, mask, mask, n_jobs)
    elif pipe.startswith("as-is") or pipe in RETRAINED:
        rep = RETRAINED.get(pipe) or pipe.split()[1]
        X2, _, _ = represent(np.where(mask[..., None], np.nan, poses2d), mask, rep)
        P, Y, margin, _ = _lift_rows(lifter, X2, poses2d, None, mask, n_jobs)
    else:
        occluded = np.where(mask[..., None], np.nan, poses2d)
        if pipe == "applyspar":
            filled = recover(occluded, mask, dictionary=dictionary,
                             n_jobs=n_jobs).poses
        elif pipe in APPLY_FCONV:
            rep = APPLY_FCONV[pipe]
            filled = recover(occluded, mask, method="fconv",
                             model=fconv_models[rep], representation=rep).poses
        else:
            filled = imputers[pipe].complete(occluded, mask).poses
        # a row the recovery could not fill is scored as failed (NaN):
        # it is lifted from a stand-in (its complete pose: a valid
        # input, whose answer is then discarded) so the batch goes on
        good = np.isfinite(filled).all(axis=(1, 2))
        filled = np.where(good[:, None, None], filled, poses2d)
        X2, _, _ = represent(filled, None, "average")
        P, Y, margin, _ = _lift_rows(lifter, X2, filled, none_mask, none_mask,
                                     n_jobs)
        P[~good] = np.nan
    return P, Y, margin


def _torch_rows(lifters, pipelines, fconv_models, retrained, notes):
    """Drop the rows whose models are absent, or that need torch when it is absent."""
    have_torch = importlib.util.find_spec("torch") is not None
    for pipe, rep in APPLY_FCONV.items():
        if pipe in pipelines and rep not in fconv_models:
            notes.append(f"no FConv '{rep}' recovery model (sparseedm fit-cnn "
                         f"--representation {rep}): {pipe} skipped")
            pipelines = [p for p in pipelines if p != pipe]
        elif pipe in pipelines:
            fconv_models[rep] = load_model(fconv_models[rep], representation=rep, kind="recover")
    for pipe, rep in RETRAINED.items():
        lf = retrained.get(rep)
        if pipe in pipelines and lf is None:
            notes.append(f"no lifter retrained on occluded '{rep}' input: {pipe} skipped")
            pipelines = [p for p in pipelines if p != pipe]
        elif pipe in pipelines and getattr(lf, "representation", rep) != rep:
            raise SparseEDMError(f"{pipe} needs a lifter retrained on '{rep}' input, this one "
                                 f"reads '{lf.representation}'")
    if not have_torch:
        torch_pipes = [p for p in pipelines if p in APPLY_FCONV
                       or (p in RETRAINED and retrained[RETRAINED[p]].method == "fconv")]
        torch_lifters = [k for k, v in lifters.items() if v.method == "fconv"]
        if torch_pipes or torch_lifters:
            notes.append("PyTorch is not installed (the sparseedm[torch] extra): skipped "
                         + ", ".join(torch_pipes + [f"lifter {k}" for k in torch_lifters]))
        pipelines = [p for p in pipelines if p not in torch_pipes]
        lifters = {k: v for k, v in lifters.items() if k not in torch_lifters}
    return lifters, pipelines
