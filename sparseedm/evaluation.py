"""The paper's evaluation protocol (Table 2, Fig. 5) against baselines.

Protocol (:func:`evaluate`)
---------------------------
1. The test poses (complete 2D poses, pixels) are the ground truth; at most
   ``max_poses`` of them, a seeded subsample.
2. For each occlusion count (1, 2, 3 joints or the Mix, where each pose draws
   1-3) a seeded mask is drawn with :func:`sparseedm.metrics.random_occlusion`;
   the seed depends on ``random_state`` and the count only, so every method and
   representation sees the same masks, and so does :func:`sweep_atoms`.
3. Each method completes the occluded poses; its completed EDM vector
   (normalised units) times the pose's scale is compared with the ground-truth
   pixel EDM by the paper's Err_ave (mean relative error over the N^2 - N
   off-diagonal entries, in per cent; observed entries count with their
   error, 0 for every method here). Err_ave is relative, so the unit cancels:
   the same number results in normalised units of the ground truth.
4. The filled poses give the 2D error of the occluded joints: pixels, and as
   a fraction of the torso (ground-truth distance neck to mid-hip, the mid-hip
   being the mean of the two hips); and the *filled-pose Err_ave*, the same
   metric on the EDM of the filled poses (column ``err_ave_filled``): the
   completed EDM need not be realisable in 2D, the filled joints are, and they
   are what a user gets. For the imputers (knn, iterative), which fill joints,
   it equals Err_ave.
5. "Where it fails": poses whose highest or lowest joint in image y (y down)
   is occluded -- the normalisation box of the observed joints is then
   smaller than the pose's, the paper's main error source -- are reported
   apart from the others.

For the sparse method ``"zero"`` and ``"average"`` give the same observed
sub-vector (both normalise by the observed bounding box), hence the same
recovery; :func:`evaluate` runs both and records the largest difference
(``report.sparse_representation_max_diff``). Among the baselines only
``mean-fill`` reads the occluded entries; ``knn``, ``iterative`` and
``nearest`` read the observed joints only, are run once per count and listed
under both representations.

``"fconv"`` (the paper's network, :mod:`sparseedm.fconv`, torch extra) runs only
when asked, with trained models (``fconv_models=``, one per representation):
each runs under the representation it was trained on, on the same masks.
"""

from __future__ import annotations

import csv
import io
import time
import warnings
from dataclasses import dataclass, field
from numbers import Integral
from pathlib import Path

import numpy as np

from . import _progress, plotting
from ._atomic import atomic_path
from ._validation import (ALPHA, ENSEMBLE, N_JOBS, Interval, check_pose_shape, check_poses,
                          validate_params)
from .baselines import BASELINES, fit_baseline, mean_fill
from .dictionary import Dictionary, load_dictionary
from .edm import pose_to_vector
from .exceptions import DictionaryError, ParameterError, PoseError, SparseEDMError
from .fconv.model import load_model
from .metrics import check_counts, err_ave, joint_error, occlusion_masks
from .normalize import REPRESENTATIONS, rms_radius, usable_rows
from ._recovery_kernel import recover_members
from .adaptation import SELF_TRAINING_ROUNDS, run_adaptation
from .ensemble import adapt_members
from .learning import OnlineDictionaryLearning, complete_pose_vectors
from .recovery import recover

__all__ = ["evaluate", "evaluate_adaptation", "sweep_atoms", "occlusion_masks", "torso_size",
           "EvaluationReport", "METHODS", "OPTIONAL_METHODS", "RESULT_COLUMNS",
           "SWEEP_COLUMNS"]

#: every method evaluate knows, in table order
METHODS = ("sparse",) + tuple(BASELINES)
#: methods run only when asked, with what they need (fconv: torch and a model)
OPTIONAL_METHODS = ("fconv",)
#: methods whose output does not depend on the occlusion representation
_REP_INDEPENDENT = ("knn", "iterative", "nearest")

RESULT_COLUMNS = (
    "method", "representation", "count", "n_poses", "n_failed",
    "err_ave_mean", "err_ave_var", "err_ave_p95", "err_ave_filled",
    "joint_err_px", "joint_err_torso", "poses_per_s",
    "n_extreme", "err_ave_extreme", "err_ave_other", "note",
)

#: the columns of :meth:`EvaluationReport.sweep_csv`, one row per atom count
SWEEP_COLUMNS = ("atoms", "err_ave_mix", "ms_per_pose", "fit_seconds", "note")

#: constraints of evaluate()'s and sweep_atoms()'s arguments (see sparseedm._validation)
_PARAMS = {
    "dictionary": [Dictionary, "path", None],
    "random_state": [Interval(Integral, 0, None), None],
    "n_jobs": N_JOBS,
    "max_poses": [Interval(Integral, 1, None), None],
    "max_train": [Interval(Integral, 1, None)],
    "alpha": ALPHA + [None],
    "alpha_recover": ALPHA,
    "n_examples": [Interval(Integral, 0, None)],
    "self_training": [Interval(Integral, 0, None), None],
    "ensemble": ENSEMBLE,
}


def check_methods(methods):
    """The evaluation's methods as a tuple, each checked against the known ones.

    Parameters
    ----------
    methods : iterable of str
        Names among :data:`METHODS` and :data:`OPTIONAL_METHODS`.

    Returns
    -------
    tuple of str
        The methods, in the order given.

    Raises
    ------
    SparseEDMError
        If the list is empty or names an unknown method.
    """
    methods = tuple(methods)
    if not methods:
        raise SparseEDMError("no method to evaluate (the list of methods is empty)")
    known = METHODS + OPTIONAL_METHODS
    unknown = [m for m in methods if m not in known]
    if unknown:
        raise SparseEDMError(
            f"unknown method(s) {', '.join(map(repr, unknown))}; known: {', '.join(known)}"
        )
    return methods


def torso_size(poses, joint_names):
    """Ground-truth distance neck to mid-hip per pose (NaN if the joints are unnamed).

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        Ground-truth poses.
    joint_names : sequence of str
        The joints' names, in the poses' order.

    Returns
    -------
    ndarray (n,)
        The torso length of each pose, in the poses' units.

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.skeleton import JOINT_NAMES
    >>> p = np.zeros((1, 14, 2)); p[0, 8] = [-1, 10]; p[0, 11] = [1, 10]
    >>> torso_size(p, JOINT_NAMES).tolist()
    [10.0]
    """
    names = list(joint_names)
    try:
        neck, rh, lh = (names.index(k) for k in ("neck", "right_hip", "left_hip"))
    except ValueError:
        return np.full(len(poses), np.nan)
    mid = (poses[:, rh] + poses[:, lh]) / 2
    return np.linalg.norm(poses[:, neck] - mid, axis=-1)


def extreme_occluded(poses, missing):
    """True where the highest or lowest joint in image y (y down) is occluded.

    Parameters
    ----------
    poses : ndarray (n, N, 2)
        Ground-truth poses.
    missing : ndarray of bool (n, N)
        The occluded joints.

    Returns
    -------
    ndarray of bool (n,)
        True for the poses whose normalisation box shrinks with the occlusion.
    """
    rows = np.arange(len(poses))
    top = poses[..., 1].argmin(axis=1)
    bottom = poses[..., 1].argmax(axis=1)
    return missing[rows, top] | missing[rows, bottom]


@dataclass
class EvaluationReport:
    """What :func:`evaluate` returns.

    Parameters
    ----------
    rows : list of dict
        One per method x representation x count, keys :data:`RESULT_COLUMNS`.
    per_action : list of dict
        Mean Err_ave per label for the Mix (label, method, representation,
        n_poses, err_ave_mean); empty without labels.
    per_pose : dict
        ``(method, representation, count) -> per-pose Err_ave array``.
    masks : dict
        ``count -> (n, N) mask`` used for every method.
    examples : dict
        A few Mix poses for figures: ``gt``, ``missing``, ``recovered``
        (sparse, "average").
    sparse_representation_max_diff : float or None
        Largest |difference| between the sparse method's completed vectors
        under "zero" and "average" (0 when they agree exactly).
    notes : list of str
        What was skipped and why.
    settings : dict
        The protocol's settings (seed, counts, poses, methods...).
    sweep : list of dict
        Filled by :func:`sweep_atoms` when attached.
    """

    rows: list
    per_action: list
    per_pose: dict
    masks: dict
    examples: dict
    sparse_representation_max_diff: float | None
    notes: list
    settings: dict
    sweep: list = field(default_factory=list)

    def table(self, method=None, representation=None, count=None):
        """Rows filtered by any of method / representation / count.

        Parameters
        ----------
        method : str, optional
            Keep the rows of this method; None: all.
        representation : str, optional
            Keep the rows of this representation; None: all.
        count : int or str, optional
            Keep the rows of this occlusion count (1, 2, 3 or ``"mix"``); None: all.

        Returns
        -------
        list of dict
            The matching rows, in report order.
        """
        return [r for r in self.rows
                if (method is None or r["method"] == method)
                and (representation is None or r["representation"] == representation)
                and (count is None or str(r["count"]) == str(count))]

    # ---------------------------------------------------------------- output
    def to_csv(self) -> str:
        """The result rows as CSV text, columns :data:`RESULT_COLUMNS`.

        Returns
        -------
        str
            CSV with a header row.
        """
        return _csv(self.rows, RESULT_COLUMNS)

    def per_action_csv(self) -> str:
        """The per-action table (Mix) as CSV text.

        Returns
        -------
        str
            CSV with a header row; only the header without labels.
        """
        return _csv(self.per_action,
                    ("label", "method", "representation", "n_poses", "err_ave_mean"))

    def sweep_csv(self) -> str:
        """The atom-count sweep (:func:`sweep_atoms`) as CSV text.

        Returns
        -------
        str
            CSV with a header row (atoms, err_ave_mix, ms_per_pose,
            fit_seconds, note); only the header without a sweep.
        """
        return _csv(self.sweep, SWEEP_COLUMNS)

    def to_markdown(self, figures=()) -> str:
        """The report as Markdown: protocol, notes, results, failures, per action, sweep.

        Parameters
        ----------
        figures : sequence of path, optional
            Figure files to link at the end (by file name).

        Returns
        -------
        str
            The Markdown text.
        """
        out = self._protocol_lines()
        if self.notes:
            out += ["## Skipped / notes", ""] + [f"- {n}" for n in self.notes] + [""]
        out += ["## Results", ""]
        cols = ("method", "representation", "count", "n_poses", "n_failed", "err_ave_mean",
                "err_ave_var", "err_ave_p95", "err_ave_filled", "joint_err_px",
                "joint_err_torso", "poses_per_s")
        heads = ("method", "repr.", "occluded", "poses", "failed", "Err_ave %", "var",
                 "p95 %", "filled-pose Err_ave %", "joint px", "joint/torso", "poses/s")
        out += _md_table(self.rows, cols, heads) + [""]
        out += self._failure_lines()
        if self.per_action:
            out += self._per_action_lines()
        if self.sweep:
            out += ["## Error and time vs number of atoms (Fig. 5)", ""]
            out += _md_table(self.sweep, SWEEP_COLUMNS,
                             ("atoms", "Mix Err_ave %", "ms / pose", "fit s", "note")) + [""]
        if figures:
            out += ["## Figures", ""] + [f"![{Path(f).stem}]({Path(f).name})" for f in figures]
            out += [""]
        return "\n".join(out)

    def _protocol_lines(self):
        """The report's title and protocol section."""
        s = self.settings
        out = [
            "# sparseedm evaluation",
            "",
            "## Protocol",
            "",
            f"- Test poses: {s['n_poses']} complete 2D poses (pixels), "
            f"{s['n_joints']} joints; seed {s['random_state']}.",
            f"- Dictionary: {s['dictionary']}",
            "- Occlusion: for each count (1, 2, 3 joints, or Mix = 1-3 drawn per pose) a seeded "
            "random mask (`sparseedm.metrics.random_occlusion`); the same masks for every "
            "method and representation.",
            "- **Err_ave** (the paper's metric, per cent): mean over the N^2-N off-diagonal "
            "entries of |E_f - E_gt| / E_gt x 100, with E_f the completed EDM in pixels "
            "(completed normalised vector x the pose's scale) and E_gt the ground-truth "
            "pixel EDM. It is a relative error, so the unit cancels. Mean, variance and "
            "95th percentile are over poses.",
            "- **filled-pose Err_ave**: the same metric on the EDM of the filled poses "
            "(observed joints as given, occluded joints placed to fit the completed "
            "EDM, :mod:`sparseedm.placement`): what the returned joints are worth. For "
            "methods that fill joints directly (the imputers) it equals Err_ave (knn, iterative).",
            "- **joint px**: mean Euclidean error of the occluded joints, pixels (mean over "
            "poses of each pose's mean); **joint/torso**: the same as a fraction of the "
            "ground-truth torso (neck to mid-hip).",
            "- **poses/s**: completion throughput (baseline fitting excluded).",
            "- Representations: `average` puts occluded joints at the mean of the observed, "
            "`zero` zeroes their EDM entries. The sparse method reads only observed "
            "entries, which are identical under both (same normalisation by the observed "
            "bounding box)" + (
                f": measured max |difference| of the completed vectors = "
                f"{self.sparse_representation_max_diff:.3g}."
                if self.sparse_representation_max_diff is not None else "."),
            "  knn, iterative and nearest also read only the observed joints: computed once, "
            "listed under both. Only mean-fill differs between them.",
            "",
        ]
        return out

    def _failure_lines(self):
        """Where it fails: poses with an extreme joint occluded vs the others."""
        out = [
            "## Where it fails",
            "",
            "Poses whose highest or lowest joint in image y is occluded (the observed "
            "bounding box, and so the normalisation, shifts) vs the others; Err_ave %.",
            "",
        ]
        cols = ("method", "representation", "count", "n_extreme", "err_ave_extreme",
                "err_ave_other")
        heads = ("method", "repr.", "occluded", "poses with extreme occluded",
                 "Err_ave extreme %", "Err_ave others %")
        first = self.settings["representations"][0]
        # one representation, plus mean-fill's other one (the only method it changes)
        fail_rows = [r for r in self.rows
                     if r["representation"] == first or r["method"] == "mean-fill"]
        out += _md_table(fail_rows, cols, heads) + [""]
        return out

    def _per_action_lines(self):
        """Mean Err_ave per action label (Mix, representation average)."""
        out = ["## Per action (Mix, representation average)", "",
               "Mean Err_ave % per label."]
        methods = list(dict.fromkeys(r["method"] for r in self.per_action))
        labels = list(dict.fromkeys(r["label"] for r in self.per_action))
        wide = []
        for lab in labels:
            row = {"label": lab}
            for r in self.per_action:
                if r["label"] == lab and r["representation"] == "average":
                    row[r["method"]] = r["err_ave_mean"]
                    row["n_poses"] = r["n_poses"]
            wide.append(row)
        out += [""] + _md_table(wide, ["label", "n_poses"] + methods,
                                ["label", "poses"] + methods) + [""]
        return out

    def write(self, directory, *, figures=True):
        """Write report.md, results.csv, per_action.csv, sweep.csv (with a sweep)
        and PNGs into `directory`.

        Returns the list of files written and a message when figures were not
        made (matplotlib missing).

        Parameters
        ----------
        directory : str or Path
            The folder to write into (created if needed).
        figures : bool, default True
            Also draw the figures (needs matplotlib).

        Returns
        -------
        written : list of Path
            The files written.
        message : str or None
            Why the figures were skipped, or None.
        """
        directory = Path(directory)
        directory.mkdir(parents=True, exist_ok=True)
        written, figs, message = [], [], None
        if figures:
            if plotting.have_matplotlib():
                figs = plotting.report_figures(self, directory)
            else:
                message = ("figures skipped: matplotlib is not installed "
                           "(pip install sparseedm[plot])")
                self.notes.append(message)
        texts = [("results.csv", self.to_csv()), ("per_action.csv", self.per_action_csv())]
        texts += [("sweep.csv", self.sweep_csv())] if self.sweep else []
        for name, text in texts + [("report.md", self.to_markdown(figs))]:
            path = directory / name
            with atomic_path(path) as tmp:
                Path(tmp).write_text(text)
            written.append(path)
        return written + list(figs), message


def _fmt(v):
    if isinstance(v, float):
        if not np.isfinite(v):
            return "-"
        if abs(v) < 1e-9:
            return "0"
        return f"{v:.4g}" if abs(v) < 1000 else f"{v:.0f}"
    return str(v)


def _md_table(rows, cols, heads):
    lines = ["| " + " | ".join(heads) + " |", "|" + "---|" * len(heads)]
    for r in rows:
        lines.append("| " + " | ".join(_fmt(r.get(c, "")) for c in cols) + " |")
    return lines


def _csv(rows, cols):
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=list(cols), extrasaction="ignore", lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{v:.6g}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue()


def _stat(x, fn):
    x = x[np.isfinite(x)]
    return float(fn(x)) if len(x) else float("nan")


def _check_poses(poses, name, n_joints):
    poses = np.asarray(poses, dtype=float)
    check_pose_shape(poses, name)
    if poses.shape[1] != n_joints:
        raise DictionaryError(
            f"the dictionary is for {n_joints} joints ({n_joints * (n_joints - 1) // 2} "
            f"distances) but {name} have {poses.shape[1]} joints"
        )
    return poses


def _recover_adapted(inputs, mask, dictionary, adapt, cache, *, self_training, ensemble,
                     n_jobs, **kw):
    """:func:`recover` for one count's inputs, adapting (and self-training) once.

    The adapted dictionaries depend on the poses, the masks and the
    adaptation settings, not on the occlusion representation, so the
    representations of one count share them (kept in `cache`).
    """
    if adapt is False:
        return recover(inputs, mask, dictionary=dictionary, n_jobs=n_jobs, adapt=False, **kw)
    if "adapted" not in cache:
        cache["adapted"] = adapt_members(dictionary, inputs, mask, adapt, ensemble,
                                         n_jobs=n_jobs, self_training=self_training)
    return recover_members(inputs, mask, *cache["adapted"], n_jobs=n_jobs, **kw)


def _check_applies(adapt, self_training, ensemble):
    """Refuse `ensemble` / `self_training` when there is no adaptation to apply them to."""
    if adapt is False or adapt is None:
        if ensemble > 1:
            raise ParameterError(f"ensemble={ensemble} averages adapted dictionaries: it "
                                 "needs adapt= (complete poses to adapt on); without "
                                 "adaptation leave ensemble at 1")
        if self_training:
            raise ParameterError(f"self_training={self_training} rounds run after an "
                                 "adaptation: they need adapt= (complete poses to adapt on)")


def evaluate(dictionary, test_poses2d, *, train_poses2d=None, labels=None,
             methods=("sparse", "mean-fill", "knn", "iterative", "nearest"),
             counts=(1, 2, 3, "mix"), representations=("average", "zero"),
             random_state=0, n_jobs=1, max_poses=None, max_train=5000,
             alpha=None, solver="fast", n_examples=4, fconv_models=None, adapt=False,
             self_training=None, ensemble=1):
    """Run the paper's protocol for each method x count x representation.

    Parameters
    ----------
    dictionary : Dictionary, str or path
        The dictionary the sparse method recovers with.
    test_poses2d : array_like (n, N, 2)
        Complete ground-truth poses in pixels; incomplete rows are dropped (noted).
    train_poses2d : array_like (n_train, N, 2), optional
        Needed by knn, iterative and nearest; without it they are skipped (noted).
    labels : array_like of str (n,), optional
        Action labels for the per-action table (Mix).
    methods : sequence of str
        Any of :data:`METHODS`.
    counts : sequence of {1, 2, 3, "mix"}
        Occluded joints per pose; ``"mix"``: 1-3 per pose.
    representations : sequence of {"average", "zero"}
        The occlusion representations evaluated.
    random_state : int
        Seed of the masks and of the subsamples.
    n_jobs : int
        joblib workers for the sparse recovery.
    max_poses : int, optional
        Evaluate a seeded subsample of this many test poses.
    max_train : int, default 5000
        The baselines are fitted on a seeded sample of at most this many
        training poses (the iterative imputer's fit grows with it: minutes at
        20,000). The Table 2 figures of the documentation's results pages
        (``docs/results/``) used 20,000 (``benchmarks/paper_protocol.py``
        passes it).
    alpha : float, optional
        Lasso penalty, passed to :func:`sparseedm.recover`.
    solver : str
        The lasso backend, passed to :func:`sparseedm.recover`.
    n_examples : int
        Number of Mix poses kept in ``report.examples`` for figures.
    fconv_models : sequence of FConvModel or path, optional
        Trained FConv recovery networks (``sparseedm fit-cnn``), at most one per
        representation: method "fconv" runs each under its own representation
        (needs the torch extra); without any, "fconv" is skipped (noted).
    adapt : False or array_like (n_adapt, N, 2)
        Passed to the sparse method's :func:`sparseedm.recover` for each
        occluded test set: complete poses to adapt on first, then
        self-training on the occluded test poses themselves (their observed
        joints only). The adaptation line of each recovery goes into the
        notes. Default False: the dictionary as given.
    self_training : int, optional
        With `adapt`: the self-training rounds (default that of
        :func:`sparseedm.recover`).
    ensemble : int, default 1
        With `adapt`: adapted dictionaries averaged (:mod:`sparseedm.ensemble`).

    Returns
    -------
    EvaluationReport
    """
    validate_params("evaluate", dict(
        dictionary=dictionary, random_state=random_state, n_jobs=n_jobs,
        max_poses=max_poses, max_train=max_train, alpha=alpha, n_examples=n_examples,
        self_training=self_training, ensemble=ensemble), _PARAMS)
    methods = check_methods(methods)
    counts = check_counts(counts)
    _check_applies(adapt, self_training, ensemble)
    for r in representations:
        if r not in REPRESENTATIONS:
            raise SparseEDMError(f"unknown representation {r!r}; use one of {REPRESENTATIONS}")
    if not isinstance(dictionary, Dictionary):
        dictionary = load_dictionary(dictionary)
    N = dictionary.n_joints
    gt, labels, notes = _test_set(test_poses2d, labels, N, max_poses, random_state)
    methods, fconv, more = _available_methods(methods, train_poses2d, fconv_models, N)
    notes += more
    fitted, more = _fit_baselines(methods, train_poses2d, N, max_train, random_state)
    notes += more
    runner = _Runner(dictionary, fitted, fconv, alpha=alpha, solver=solver, n_jobs=n_jobs,
                     adapt=adapt, self_training=self_training, ensemble=ensemble)

    n = len(gt)
    masks = occlusion_masks(n, N, counts, random_state)
    size = _pose_sizes(gt)  # the errors' unit, then pixels again
    gt_vec = pose_to_vector(gt / size[:, None, None])
    torso = torso_size(gt / size[:, None, None], dictionary.joint_names)
    if not np.isfinite(torso).any():
        notes.append("joint names lack neck/hips: joint/torso column is empty")
    runner.warm_up(methods, gt[:1], masks[counts[0]][:1])

    rows, per_pose, per_action, examples = [], {}, [], {}
    sparse_vectors = {}
    for c in counts:
        mask = masks[c]
        extreme = extreme_occluded(gt, mask)
        inputs = np.where(mask[..., None], np.nan, gt)
        cache, adapted = {}, {}
        for m in methods:
            for rep in representations:
                if m == "fconv" and rep not in fconv:
                    continue
                res, note, more = runner.run(m, rep, c, inputs, mask, cache, adapted)
                notes += more
                if m == "sparse":
                    sparse_vectors[(c, rep)] = res.vectors
                scores, e = _scores(res, gt, gt_vec, mask, torso, extreme, size)
                per_pose[(m, rep, c)] = e
                rows.append({"method": m, "representation": rep, "count": c, "n_poses": n,
                             **scores, "note": note})
                if c == "mix" and labels is not None:
                    per_action.extend(_per_action(labels, e, m, rep))
                if m == "sparse" and rep == representations[0] and (
                        c == "mix" or not examples):
                    k = min(n_examples, n)
                    examples = {"gt": gt[:k], "missing": mask[:k], "recovered": res.poses[:k],
                                "err_ave": e[:k], "count": c}
    max_diff = None
    if "sparse" in methods and set(representations) >= {"average", "zero"}:
        diffs = [np.nanmax(np.abs(sparse_vectors[(c, "average")] - sparse_vectors[(c, "zero")]))
                 for c in counts]
        max_diff = float(max(diffs))
    settings = {
        "n_poses": n, "n_joints": N, "random_state": random_state,
        "methods": list(methods), "counts": list(counts),
        "representations": list(representations),
        "dictionary": f"{dictionary.n_components} atoms, recovery alpha "
                      f"{dictionary.alpha_recover if alpha is None else alpha:g}, solver {solver}",
    }
    return EvaluationReport(rows=rows, per_action=per_action, per_pose=per_pose,
                            masks=masks, examples=examples,
                            sparse_representation_max_diff=max_diff,
                            notes=notes, settings=settings)


def _test_set(test_poses2d, labels, n_joints, max_poses, random_state):
    """The complete test poses evaluated (a seeded subsample with `max_poses`),
    their labels, and notes saying what was left out."""
    notes = []
    gt = _check_poses(test_poses2d, "test poses", n_joints)
    if labels is not None:
        labels = np.asarray(labels).astype(str)
        if labels.shape != (len(gt),):
            raise PoseError(f"labels must have shape ({len(gt)},), got {labels.shape}")
    ok = usable_rows(gt)
    if not ok.all():
        notes.append(f"{int((~ok).sum())} of {len(gt)} test poses are incomplete or "
                     "degenerate and were left out (the ground truth must be complete)")
    index = np.flatnonzero(ok)
    if max_poses is not None and len(index) > max_poses:
        rng = np.random.default_rng([int(random_state or 0), 5])
        index = np.sort(rng.choice(index, int(max_poses), replace=False))
        notes.append(f"evaluated a seeded subsample of {len(index)} test poses")
    if len(index) == 0:
        raise PoseError("no complete test poses to evaluate")
    gt = gt[index]
    labels = labels[index] if labels is not None else None
    if labels is None:
        notes.append("no labels: per-action table skipped")
    return gt, labels, notes


def _available_methods(methods, train_poses2d, fconv_models, n_joints):
    """The methods that can run (those lacking training poses or a model are
    skipped), the FConv models by representation, and notes on both."""
    notes = []
    if train_poses2d is None:
        need = [m for m in methods if BASELINES.get(m)]
        if need:
            notes.append(f"no training poses: skipped {', '.join(need)} (they need --train)")
            methods = tuple(m for m in methods if m not in need)
    fconv = {}
    if "fconv" in methods:
        fconv = _load_fconv(fconv_models or (), n_joints)
        if not fconv:
            notes.append("no FConv model: skipped fconv (it needs --fconv-model)")
            methods = tuple(m for m in methods if m != "fconv")
        for rep, model in fconv.items():
            t = model.meta.get("training", {})
            notes.append(f"fconv {rep}: trained on {t.get('n_train', '?')} poses, "
                         f"{t.get('epochs', '?')} epochs, "
                         f"{'with' if model.symmetrize else 'without'} symmetrisation")
    if not methods:  # an empty report would say nothing, with exit code 0
        raise SparseEDMError("nothing to evaluate: " + "; ".join(notes))
    return methods, fconv, notes


def _fit_baselines(methods, train_poses2d, n_joints, max_train, random_state):
    """The baselines among `methods` that need training poses, fitted on them,
    and a note on each fit."""
    fitted, notes = {}, []
    for m in methods:
        if BASELINES.get(m):
            train = _check_poses(train_poses2d, "training poses", n_joints)
            sampled = max_train is not None and len(train) > max_train
            _progress.say(f"fitting the {m} baseline on " + (
                f"a seeded sample of {max_train:,} of the {len(train):,} training poses"
                if sampled else f"{len(train):,} training poses"))
            fitted[m] = fit_baseline(m, train, max_train=max_train,
                                     random_state=random_state)
            notes.append(f"{m}: fitted on {fitted[m].n_train_} complete training poses"
                         + (f" (a seeded sample of the {len(train)} given, --max-train)"
                            if sampled else "") + f" in {fitted[m].fit_seconds_:.2f} s")
    return fitted, notes


@dataclass
class _Runner:
    """Runs one method on one count's occluded inputs, as :func:`evaluate` asks."""

    dictionary: Dictionary
    fitted: dict
    fconv: dict
    alpha: float = None
    solver: object = "fast"
    n_jobs: int = 1
    adapt: object = False
    self_training: int = None
    ensemble: int = 1

    def warm_up(self, methods, gt, mask):
        """One-time compilation, set-up and torch import out of the timings."""
        if "sparse" in methods:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                recover(np.where(mask[:, :, None], np.nan, gt), mask,
                        dictionary=self.dictionary, alpha=self.alpha, solver=self.solver,
                        adapt=False)
        for rep, model in self.fconv.items():
            recover(np.where(mask[:, :, None], np.nan, gt), mask, method="fconv", model=model,
                    representation=rep)

    def run(self, m, rep, c, inputs, mask, cache, adapted):
        """``(result, row note, report notes)`` of method `m` under representation
        `rep`: the representation-independent baselines are run once per count
        (kept in `cache`), the adapted dictionaries made once per count (kept in
        the cache `adapted`)."""
        if m in _REP_INDEPENDENT and m in cache:
            return (cache[m], "reads observed joints only: same as the other representation",
                    [])
        _progress.say(f"evaluating {m} ({rep}) on {len(inputs):,} poses, occluded joints: {c}")
        notes = []
        if m == "sparse":
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                res = _recover_adapted(inputs, mask, self.dictionary, self.adapt, adapted,
                                       alpha=self.alpha, representation=rep,
                                       solver=self.solver, n_jobs=self.n_jobs,
                                       self_training=self.self_training,
                                       ensemble=self.ensemble)
            if res.adaptation is not None:
                notes.append(f"sparse, {c} missing, {rep}: {res.adaptation.line()}")
            if res.members > 1:
                notes.append(f"sparse, {c} missing, {rep}: the mean of an ensemble of "
                             f"{res.members} adapted dictionaries (sparseedm.ensemble)")
        elif m == "fconv":
            res = recover(inputs, mask, method="fconv", model=self.fconv[rep],
                          representation=rep)
        elif m == "mean-fill":
            res = mean_fill(inputs, mask, rep)
        else:
            res = self.fitted[m].complete(inputs, mask)
            cache[m] = res
        return res, "", notes


def _pose_sizes(gt):
    """Each ground-truth pose's RMS radius (1 where it is not a positive finite
    number): the errors are computed in units of it, before their norms, whose
    squares overflow from about 1e154 pixels, then turned back into pixels."""
    _, size = rms_radius(gt, np.zeros(gt.shape[:-1], dtype=bool))
    return np.where(np.isfinite(size) & (size > 0), size, 1.0)


def _edm_errors(res, gt_vec, size):
    """Per-pose Err_ave of `res`'s completed EDMs (NaN where the pose failed)
    against `gt_vec`, the truth's EDM vectors in units of `size`."""
    with np.errstate(invalid="ignore"):
        e = err_ave(res.vectors * (res.scale / size)[:, None], gt_vec)
    return np.where(res.ok, e, np.nan)


def _scores(res, gt, gt_vec, mask, torso, extreme, size):
    """A result row's numbers (:data:`RESULT_COLUMNS` from ``n_failed`` to
    ``err_ave_other``) and the per-pose Err_ave (NaN where the pose failed);
    `gt_vec` and `torso` in units of each pose's `size` (:func:`_pose_sizes`)."""
    good = res.ok
    n = len(gt)
    e = _edm_errors(res, gt_vec, size)
    # the same metric on the EDM of the filled poses (the joints a
    # user gets: the occluded ones placed from the completed EDM)
    filled = res.poses / size[:, None, None]
    with np.errstate(invalid="ignore", divide="ignore"):
        e_filled = np.where(good, err_ave(pose_to_vector(filled), gt_vec), np.nan)
    je = joint_error(filled, gt / size[:, None, None], mask)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        je_pose = np.where(good, np.nanmean(je, axis=1), np.nan)
    return {
        "n_failed": int((~good).sum()),
        "err_ave_mean": _stat(e, np.mean),
        "err_ave_var": _stat(e, np.var),
        "err_ave_p95": _stat(e, lambda x: np.percentile(x, 95)),
        "err_ave_filled": _stat(e_filled, np.mean),
        "joint_err_px": _stat(je_pose * size, np.mean),
        "joint_err_torso": _stat(je_pose / torso, np.mean),
        "poses_per_s": n / res.seconds if res.seconds > 0 else float("nan"),
        "n_extreme": int(extreme.sum()),
        "err_ave_extreme": _stat(e[extreme], np.mean),
        "err_ave_other": _stat(e[~extreme], np.mean),
    }, e


def _per_action(labels, e, m, rep):
    """The per-action rows (Mix) of one method and representation."""
    return [{"label": lab, "method": m, "representation": rep,
             "n_poses": int((labels == lab).sum()),
             "err_ave_mean": _stat(e[labels == lab], np.mean)}
            for lab in dict.fromkeys(labels)]


def _load_fconv(models, n_joints):
    """representation -> FConvModel, one per representation."""
    out = {}
    for item in models:
        model = load_model(item, n_joints=n_joints, kind="recover")
        if model.representation in out:
            raise SparseEDMError(f"two FConv models for representation "
                                 f"{model.representation!r}; give one per representation")
        out[model.representation] = model
    return out


def sweep_atoms(train_poses2d, test_poses2d, atoms=(100, 250, 500, 1000, 2000), *,
                alpha=1.6, alpha_recover=0.002, n_passes=1, batch_size=512,
                random_state=0, max_poses=None, representation="average", n_jobs=1,
                solver="fast"):
    """Fig. 5: Mix Err_ave and recovery time per pose vs the number of atoms.

    Each dictionary is learned with :class:`sparseedm.learning.OnlineDictionaryLearning`
    (the same alpha for all) on the training poses' complete normalised EDM
    vectors; each test pose is coded over it alone (``adapt=False``, as
    :func:`evaluate`'s ``sparse`` row); the Mix masks are those of
    :func:`evaluate` with the same seed.
    A size larger than the number of training poses is skipped (noted).

    Parameters
    ----------
    train_poses2d : array_like (n_train, N, 2)
        Training poses; their complete rows are learned on.
    test_poses2d : array_like (n, N, 2)
        Complete ground-truth test poses, pixels.
    atoms : sequence of int
        The dictionary sizes.
    alpha : float, default 1.6
        The learning's sparsity penalty.
    alpha_recover : float, default 0.002
        The recovery's lasso penalty.
    n_passes : int, default 1
        Passes of the online learning over the training vectors.
    batch_size : int, default 512
        Mini-batch size of the online learning.
    random_state : int, default 0
        Seed of the masks, the subsample and the learning.
    max_poses : int, optional
        Evaluate a seeded subsample of this many test poses.
    representation : {"average", "zero"}, default "average"
        The occlusion representation of the recovery.
    n_jobs : int, default 1
        joblib workers for the recovery.
    solver : str, default "fast"
        The lasso backend.

    Returns
    -------
    list of dict
        ``atoms, err_ave_mix, ms_per_pose, fit_seconds, note`` per size.
    """
    validate_params("sweep_atoms", dict(
        random_state=random_state, n_jobs=n_jobs, max_poses=max_poses, alpha=alpha,
        alpha_recover=alpha_recover), _PARAMS)
    if not all(isinstance(k, Integral) and not isinstance(k, bool) and k >= 1 for k in atoms):
        raise ParameterError(f"sweep_atoms: atoms must be integers >= 1, got {atoms!r}")
    X, _ = complete_pose_vectors(check_poses(train_poses2d, "sweep_atoms", "train_poses2d"))
    test = check_poses(test_poses2d, "sweep_atoms", "test_poses2d")
    test = test[usable_rows(test)]
    if max_poses is not None and len(test) > max_poses:
        rng = np.random.default_rng([int(random_state or 0), 5])
        test = test[np.sort(rng.choice(len(test), int(max_poses), replace=False))]
    N = test.shape[1]
    mask = occlusion_masks(len(test), N, ("mix",), random_state)["mix"]
    size = _pose_sizes(test)
    gt_vec = pose_to_vector(test / size[:, None, None])
    inputs = np.where(mask[..., None], np.nan, test)
    out = []
    for k in atoms:
        k = int(k)
        if k > len(X):
            out.append({"atoms": k, "err_ave_mix": float("nan"), "ms_per_pose": float("nan"),
                        "fit_seconds": float("nan"),
                        "note": f"skipped: {len(X)} training poses < {k} atoms"})
            continue
        t0 = time.perf_counter()
        odl = OnlineDictionaryLearning(k, alpha=alpha, batch_size=batch_size,
                                       n_passes=n_passes, random_state=random_state).fit(X)
        fit_s = time.perf_counter() - t0
        d = Dictionary(odl.components_ / np.linalg.norm(odl.components_, axis=1, keepdims=True),
                       alpha_recover=alpha_recover,
                       alpha_train=alpha)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            res = recover(inputs, mask, dictionary=d, representation=representation,
                          n_jobs=n_jobs, solver=solver, adapt=False)
        e = _edm_errors(res, gt_vec, size)
        out.append({"atoms": k, "err_ave_mix": _stat(e, np.mean),
                    "ms_per_pose": 1000 * res.seconds / len(test), "fit_seconds": fit_s,
                    "note": ""})
    return out


# --------------------------------------------------------------------------
# the adaptation evaluation protocol (moved here from sparseedm.adaptation)

def evaluate_adaptation(dictionary, test_poses2d, adapt_poses2d, *,
                        methods=("sparse", "mean-fill", "knn", "iterative", "nearest"),
                        counts=("mix",), representations=("average",), random_state=0,
                        n_jobs=1, max_poses=None, max_train=20000, alpha=None, fconv_models=(),
                        self_training=SELF_TRAINING_ROUNDS, ensemble=1, **adapt_kwargs):
    """:func:`sparseedm.evaluation.evaluate` with the adaptation protocol.

    The dictionary (learned on source A) is evaluated cold (``sparse``) and
    adapted (``sparse-adapted``): ``recover(..., adapt=adapt_poses2d)`` on each
    occluded test set, i.e. :func:`run_adaptation` on `adapt_poses2d` (the
    dictionary the guard chose) followed by :func:`self_train` on the occluded
    test poses (their observed joints; `self_training` rounds, default
    ``SELF_TRAINING_ROUNDS``; with non-default adaptation settings in
    `adapt_kwargs` the row is the adaptation alone); the baselines that need
    training poses are fitted on the same adaptation poses. `test_poses2d` should come from other
    clips of the adaptation poses' source (complete poses, occluded by the
    protocol's seeded masks). `fconv_models` are passed to ``evaluate`` (FConv
    rows, not adapted). ``ensemble=K`` averages K adapted dictionaries in the
    ``sparse-adapted`` row (:mod:`sparseedm.ensemble`).

    Parameters
    ----------
    dictionary : Dictionary, str or path
        The dictionary learned on source A.
    test_poses2d : array_like (n, N, 2)
        Complete ground-truth test poses of the target source, pixels.
    adapt_poses2d : array_like (n_adapt, N, 2)
        Complete poses of the target source to adapt on (and to fit the
        baselines on).
    methods : sequence of str
        The methods, as :func:`evaluate`; ``sparse`` adds ``sparse-adapted``.
    counts : sequence of {1, 2, 3, "mix"}
        Occluded joints per pose, as :func:`evaluate`.
    representations : sequence of {"average", "zero"}
        The occlusion representations, as :func:`evaluate`.
    random_state : int, default 0
        Seed of the masks, subsamples and adaptation.
    n_jobs : int, default 1
        joblib workers for the sparse recovery.
    max_poses : int, optional
        Evaluate a seeded subsample of this many test poses.
    max_train : int, default 20000
        Most adaptation poses the baselines are fitted on.
    alpha : float, optional
        Lasso penalty, passed to :func:`sparseedm.recover`.
    fconv_models : sequence of FConvModel or path
        Trained FConv networks, as :func:`evaluate`.
    self_training : int
        Self-training rounds after the adaptation.
    ensemble : int, default 1
        Adapted dictionaries averaged in the ``sparse-adapted`` row.
    **adapt_kwargs
        Adaptation settings passed to :func:`run_adaptation`.

    Returns
    -------
    EvaluationReport
        Rows for ``sparse``, ``sparse-adapted`` and the baselines; the notes
        and ``settings["adaptation"]`` say what adaptation did.
    """
    validate_params("evaluate_adaptation", {"self_training": self_training,
                                            "ensemble": ensemble}, _PARAMS)
    if ensemble > 1 and adapt_kwargs:
        raise SparseEDMError("ensemble runs recover()'s default adaptation: it cannot be "
                             f"combined with adaptation settings ({', '.join(adapt_kwargs)})")
    self_training = SELF_TRAINING_ROUNDS if self_training is None else self_training
    if not isinstance(dictionary, Dictionary):
        dictionary = load_dictionary(dictionary)
    adapt_poses2d = np.asarray(adapt_poses2d, dtype=float)
    common = dict(counts=counts, representations=representations, random_state=random_state,
                  n_jobs=n_jobs, max_poses=max_poses, alpha=alpha)
    report = evaluate(dictionary, test_poses2d, train_poses2d=adapt_poses2d, methods=methods,
                      max_train=max_train, fconv_models=fconv_models, **common)
    res = run_adaptation(dictionary, adapt_poses2d, random_state=random_state, n_jobs=n_jobs,
                         **adapt_kwargs)
    report.notes.append(res.line().replace("adaptation:", "sparse-adapted:", 1))
    report.settings["adaptation"] = res.summary()
    if "sparse" in methods:
        if (self_training or ensemble > 1) and res.adapted and not adapt_kwargs:
            # the protocol as recover() runs it: adapt, then self-train on the test inputs
            adapted = evaluate(dictionary, test_poses2d, methods=("sparse",),
                               adapt=adapt_poses2d, self_training=self_training,
                               ensemble=ensemble, **common)
            report.notes.extend(n for n in adapted.notes
                                if "self-training" in n or "ensemble of" in n)
        else:
            adapted = evaluate(res.dictionary, test_poses2d, methods=("sparse",), **common)
        rows = []
        for r in report.rows:
            rows.append(r)
            if r["method"] == "sparse":
                twin = adapted.table(method="sparse", representation=r["representation"],
                                     count=r["count"])[0]
                rows.append(dict(twin, method="sparse-adapted",
                                 note="" if res.adapted else "guard kept the base dictionary"))
        report.rows = rows
        for (m, rep, c), e in adapted.per_pose.items():
            report.per_pose[("sparse-adapted", rep, c)] = e
        report.settings["methods"] = list(report.settings["methods"]) + ["sparse-adapted"]
    return report
