"""Recovery: the lasso on the observed sub-dictionary, the Eq. 10 merge, joint placement.

For a pose with occluded joints (Guo & Dai, sec. 3):

1. normalise it (by the dictionary's ``recovery_scale`` rule:
   :func:`sparseedm.normalize.normalize`) and form its EDM vector T under the
   chosen representation;
2. keep the entries of T that touch no occluded joint, T_sub, and the same
   rows of the dictionary, D_sub;
3. solve ``min_c 0.5 ||T_sub - D_sub c||^2 + alpha_eff ||c||_1``;
4. ``T_re = D c``; the completed vector keeps the observed entries of T and
   takes the occluded ones from T_re (the paper's Eq. 10);
5. beyond the paper: place each occluded joint from its recovered distances
   (:mod:`sparseedm.placement`) and undo the normalisation, so the filled
   poses are in the caller's own pixel frame; observed joints stay exactly as
   given.

Alpha scaling: with ``alpha_scaling="entries"`` (the shipped dictionaries'
choice) ``alpha_eff = alpha * m_obs / m``, where m_obs of the m entries are
observed: the penalty keeps its weight per observed distance, as the data term
shrinks with the entries left. The recommended alpha of a dictionary was chosen
with the same rule on a validation split.

Poses are sorted by missing pattern (at most 469 patterns for up to 3 of 14
joints) and cut into chunks that joblib spreads over CPU cores; each chunk
goes to the solver's ``solve_masked``, which solves every row on its observed
entries (the fast solver in one kernel call from one cached Gram matrix of the
whole dictionary; the others per pattern group).
"""

from __future__ import annotations

import warnings

from . import _progress
from ._parallel import one_client
from ._recovery_base import (STATUSES, RecoveryResult, cold_prior, screen_poses,
                             validate_poses)
from ._recovery_kernel import (RECOVER_PARAMS, preset_solver, recover_members, recover_sparse,
                                solve_chunk)
from ._validation import Options, check_adapt, check_frames, validate_params
from .normalize import REPRESENTATIONS, representation_for
from .cold_bank import bank_step, cold_bank_stack
from .dictionary import Dictionary, check_gram_memory, load_dictionary
from .ensemble import adapt_members
from .exemplars import EXEMPLAR_OPTIONS, blend_many_hidden, blend_parts, blends, finish_blend
from .exceptions import ParameterError, SparseEDMError
from .keypoints import origin_joints
from .outliers import check_confidence, mark_outliers, note_outliers
from .temporal.recover import recover_temporal
from .uncertainty import joint_uncertainty

__all__ = ["recover", "RecoveryResult", "OcclusionRecoverer", "STATUSES", "screen_poses",
           "check_options_apply"]

# the names recover() was built from before the split, kept for a release
_recover, _recover_members, _solve_chunk = recover_sparse, recover_members, solve_chunk


#: constraints of recover()'s arguments (defined with the kernel, which the guard
#: of adaptation also validates against)
#: the recovery settings the blend of poses with many hidden joints shares with the path
BLEND_SETTINGS = ("representation", "n_jobs", "chunk_size", "progress")
_PARAMS = dict(RECOVER_PARAMS, representation=[Options(REPRESENTATIONS), None],
               outliers=["boolean"], exemplars=[Options(EXEMPLAR_OPTIONS)],
               mirror=["boolean", Options(("auto",)), None])


def check_options_apply(caller, *, method, model, backend, scheduler, adapt, ensemble,
                        preset="default", self_training=None, exemplars="auto"):
    """Refuse options that would be silently ignored (a ParameterError naming them).

    Shared by :func:`recover` and :func:`sparseedm.batch.recover_file` (the
    command line's path), which check these combinations before any work.

    Parameters
    ----------
    caller : str
        The function or command named in the message.
    method : {"sparse", "fconv"}
        The recovery method asked for.
    model : object or None
        The FConv network given, if any (used by ``method="fconv"`` only).
    backend : str or None
        The joblib backend asked for.
    scheduler : str or None
        The Dask scheduler address given, if any (used by ``backend="dask"``
        only).
    adapt : "auto", False, None or array_like
        The adaptation asked for; False or None means none.
    ensemble : int
        Adapted dictionaries to average.
    preset : {"default", "fast"}, default "default"
        The preset asked for.
    self_training : int or None, default None
        The self-training rounds asked for (None: the default).
    exemplars : {"auto", False}, default "auto"
        The exemplar rule asked for.

    Raises
    ------
    ParameterError
        A `model` with ``method="sparse"``, a `scheduler` without
        ``backend="dask"``, ``ensemble > 1`` without adaptation, or
        ``preset="fast"`` (which learns nothing) with ``method="fconv"``,
        ``ensemble > 1``, self-training rounds or ``exemplars=False`` (its
        atoms are the file's own poses whatever the rule says).

    Examples
    --------
    >>> check_options_apply("recover", method="sparse", model=None, backend=None,
    ...                     scheduler=None, adapt="auto", ensemble=1)
    >>> check_options_apply("recover", method="sparse", model=None, backend=None,
    ...                     scheduler=None, adapt=False, ensemble=3)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.ParameterError: recover: ensemble=3 averages adapted dictionaries: ...
    """
    if method == "sparse" and model is not None:
        raise ParameterError(f"{caller}: model is the FConv network of method='fconv'; "
                             "method='sparse' codes with dictionary=")
    if scheduler is not None and backend != "dask":
        raise ParameterError(f"{caller}: scheduler is a Dask address: it needs "
                             "backend='dask' (--backend dask)")
    if ensemble > 1 and (adapt is False or adapt is None):
        raise ParameterError(f"{caller}: ensemble={ensemble} averages adapted "
                             "dictionaries: it needs adaptation (drop adapt=False / "
                             "--no-adapt)")
    if preset == "fast":
        asked = [name for name, used in (("method='fconv'", method == "fconv"),
                                         (f"ensemble={ensemble}", ensemble > 1),
                                         (f"self_training={self_training}",
                                          bool(self_training)),
                                         ("exemplars=False", exemplars is False)) if used]
        if asked:
            raise ParameterError(f"{caller}: preset='fast' learns no dictionary (its atoms "
                                 "are the file's own poses, when it has enough), so "
                                 f"{' and '.join(asked)} would be ignored: drop "
                                 f"{'them' if len(asked) > 1 else 'it'} or the preset")


def recover(poses, missing=None, *, dictionary=None, alpha=None,
            representation=None, solver="fast", n_jobs=1, chunk_size=2048,
            positive=None, progress=False, backend=None, scheduler=None,
            method="sparse", model=None, adapt="auto", self_training=None, ensemble=1,
            tracks=None, frames=None, temporal=True, preset="default",
            confidence=None, outliers=True, exemplars="auto", mirror=None):
    """Recover the occluded joints of 2D poses.

    Parameters
    ----------
    poses : array_like, shape (n, N, 2) or (N, 2)
        Keypoints in the caller's own pixel frame.
    missing : array_like of bool, shape (n, N), optional
        True where a joint is occluded; by default NaN coordinates mark them.
    dictionary : Dictionary, str or path, optional
        None means the shipped default, ``cmu-all-k2000``: the base adaptation
        starts from. With ``adapt=False`` and poses coded one by one (no
        `frames`), None means ``cmu-coco-k2932`` (its CMU atoms plus COCO's
        people) with ``mirror="auto"``, the answers then averaged with a
        local Gaussian's over the shipped pose bank
        (:mod:`sparseedm.cold_bank`): the cold prior that does best on
        photos of real people and on motion capture it did not learn from
        (``docs/explanation/settings.md``, "Without adaptation");
        ``dictionary="default"`` codes over the default alone (and any
        dictionary given: its codes, no bank).
    alpha : float, optional
        Lasso penalty; default the dictionary's recommended ``alpha_recover``.
        Scaled per pose by the dictionary's ``alpha_scaling`` rule.
    representation : {"average", "zero"}, optional
        How occluded joints enter the EDM vector. Default: the one an FConv
        `model` was trained on (another one is refused), else ``"average"``.
    solver : {"fast", "clarabel", "cvxpy-naive"} or a BaseSolver
        "fast" (default) is the certified LARS path, which finishes any pose
        its path leaves uncertified by feature-sign search and hands what that
        cannot certify to Clarabel; "clarabel" is cvxpy + Clarabel throughout.
    n_jobs : int, default 1
        joblib workers over chunks of poses; -1 for all cores. The "fast"
        solver's kernels already run on numba's threads (all cores) in this
        process: its poses are cut into chunks only when each worker gets two
        or more chunks of at least 128 poses and the workers, one numba thread
        each, are as many as numba's threads (fewer would leave cores idle).
        Process workers (``backend="loky"``) share out numba's threads, cores
        // n_jobs each.
    chunk_size : int, default 2048
        Poses per task.
    positive : bool, optional
        Non-negative codes; default the dictionary's ``positive_code``.
    progress : bool, default False
        Show a progress bar over chunks, and a line on stderr as each long
        stage starts (adaptation, the check of the file's own poses, the
        compilation of the numba kernels), as ``sparseedm recover`` does.
    backend : {None, "loky", "threading", "dask"}, optional
        joblib backend for the chunks when ``n_jobs != 1``; None means
        threads for the "fast" solver (its compiled kernels release the GIL)
        and loky processes for the others. ``"dask"`` sends the chunks to a Dask
        cluster (``pip install sparseedm[dask]``), all its workers being used:
        those of the final recovery and, with adaptation, those of the guard's
        and the self-training rounds' recoveries (every ensemble member's too),
        over one client for the whole call; the same seeds and chunks, so the
        same poses as the local run. The online learning of the adapted atoms
        and the filters' coding stay in this process (the learning is sequential
        by nature: each mini-batch updates the atoms the next one is coded on).
    scheduler : str, optional
        With ``backend="dask"``: the scheduler address (``tcp://host:8786``);
        None uses the Dask client already created in this process.
    method : {"sparse", "fconv"}, default "sparse"
        "fconv" completes the EDM with a trained FConv network instead
        (:mod:`sparseedm.fconv`, needs ``sparseedm[torch]``); the dictionary,
        alpha, solver, n_jobs, backend and positive arguments are then unused.
    model : FConvModel, str or path, optional
        The network for ``method="fconv"`` (``sparseedm fit-cnn``), used with
        the representation it was trained on.
    adapt : "auto", False or array_like (n_adapt, N, 2)
        (sparse method only)
        ``"auto"`` (default): when the poses hold at least
        :data:`sparseedm.adaptation.MIN_COMPLETE_POSES` complete plausible
        poses, either those poses become the dictionary's only atoms (see
        `exemplars`) or the dictionary is first adapted on them (guarded:
        kept only if better on a held-back slice, see :mod:`sparseedm.adaptation`).
        ``False``: recover with the dictionary as given. An array: adapt on
        those (complete) poses instead, e.g. other files of the same source.
        When the adaptation is not adopted (too few complete poses, or the
        guard keeps the base), those complete poses join the base dictionary
        as extra atoms instead (:mod:`sparseedm.file_atoms`).
        ``res.adaptation`` says what was done.
    self_training : int, optional
        After an adopted adaptation, this many rounds of transductive
        self-training on the incomplete poses (recover a seeded sample of
        them, adapt again on the complete plus the filled poses; the last
        round is guarded: :func:`sparseedm.adaptation.self_train`); default
        :data:`sparseedm.adaptation.SELF_TRAINING_ROUNDS`, 0 turns it off
        (with frames, the default runs them from
        :data:`sparseedm.temporal.recover.SELF_TRAINING_MIN_FRAMES` poses on:
        :func:`sparseedm.temporal.recover.adapts`). What the rounds gain and cost:
        ``docs/explanation/settings.md``, "Adaptation and self-training".
    ensemble : int, default 1
        (with adaptation) Adapt this many times (seeds 0, 1, ...), recover
        with each adapted dictionary and return the mean of the filled poses
        and EDM vectors (:mod:`sparseedm.ensemble`): lower error, K times the
        work. Stays at one member when the adaptation is not adopted, and at
        the path's own dictionaries when the file's complete poses are the
        atoms (`exemplars`: nothing is learned, every seed would code with
        the same atoms); a ``UserWarning`` then says why, and
        ``res.summary()["adaptation"]["ensemble"]`` records the members
        asked and those that ran.
    tracks : array_like (n,), optional
        With `frames`: the person of each pose (any values); None means all
        poses are one person, or, when some frame holds several poses, the
        tracks :func:`sparseedm.temporal.linking.link_tracks` links them
        into (returned as ``linked_tracks``).
    frames : array_like of int (n,), optional
        Frame number of each pose: turns on temporal recovery
        (:mod:`sparseedm.temporal`), which fills each track's occluded joints
        from the frames around them and the per-frame answer. Any order;
        skipped numbers are frames where the person was not seen. The
        readers' rule: booleans and dates are refused (ParameterError); a
        number that is not a whole frame number leaves its pose per frame.
    temporal : bool, default True
        False ignores `tracks` and `frames`: every pose on its own, exactly as
        without them.
    preset : {"default", "fast"}, default "default"
        ``"default"``: the settings above as they are. ``"fast"``: no
        adaptation and no self-training; under ``adapt="auto"`` (or an array)
        the complete poses (at least
        :data:`~sparseedm.adaptation.MIN_COMPLETE_POSES`; every one) are the
        dictionary's only atoms (:func:`sparseedm.file_atoms.resolve_fast`;
        with fewer complete poses they join the base dictionary's atoms), and
        each occluded pose is coded by a local ridge over its most correlated
        atoms (:class:`~sparseedm.solvers.local_ridge.LocalRidgeSolver` with
        :data:`sparseedm._recovery_kernel.FAST_RIDGE`), not the lasso, when
        `solver` is "fast" (another solver keeps its lasso; `alpha` is the
        lasso's; non-negative codes, `positive` or the dictionary's
        ``positive_code``, keep the lasso too: the local ridge's are signed). The statuses and refusals are the same as with the
        defaults; "recovered" there means the ridge's normal equations were
        solved (`gap`: their relative residual). It skips the defaults' fixed
        cost of adaptation and self-training (tens of seconds) and the
        lasso (``docs/explanation/settings.md``, "Presets", and the accuracy-speed
        frontier of the results pages). Per pose only: with `frames` it needs
        ``temporal=False``; `ensemble`, `self_training` and ``exemplars=False``
        are refused with it.
    confidence : array_like (n, N), optional
        The detector's score of each joint in [0, 1] (NaN: none). Turns on the
        outlier check: an observed joint scored below 0.3 that the pose model
        and its track (with `frames`) both contradict is treated as missing
        and filled (:mod:`sparseedm.outliers`). Scores do not make joints
        missing here: drop those under your cut-off first (the file readers
        do, :func:`sparseedm.keypoints.read_keypoints`).
    outliers : bool, default True
        False turns the outlier check off (the scores are then unused).
    exemplars : {"auto", False}, default "auto"
        (with ``adapt="auto"``, per pose; the video path, with `frames`, does
        not use it) ``"auto"``: the file's own complete poses are the only
        atoms, nothing learned and no self-training, when they are the better
        choice (:mod:`sparseedm.exemplars`): always from
        :data:`~sparseedm.exemplars.EXEMPLAR_MIN_POSES` complete poses; from
        :data:`~sparseedm.adaptation.MIN_COMPLETE_POSES` on when they recover
        held-back complete poses' hidden joints about as well as the base
        dictionary with them as extra atoms or better (within
        :data:`~sparseedm.exemplars.EXEMPLAR_MARGIN`); or, when the check
        prefers the mean, the mean of the answers of those atoms, of them with
        their mirror images, and of the base dictionary with them as extra
        atoms (still nothing learned). Below MIN_COMPLETE_POSES, from
        :data:`~sparseedm.exemplars.FEW_MIN_POSES` of them, the base with
        them as extra atoms is averaged with the base with them and their
        mirror images as extra atoms when that recovers held-back complete
        poses better. An ensemble then stays at those members (warned, see
        `ensemble`). Whichever of
        these paths (nothing learned) ran, a pose with at least
        :data:`~sparseedm.exemplars.BLEND_MIN_HIDDEN` hidden joints gets the
        mean of its answer and the local ridge's over the file's complete
        poses as the only atoms
        (:func:`~sparseedm.exemplars.blend_many_hidden`; from
        :data:`~sparseedm.exemplars.BLEND_MIN_POSES` of them, with the
        default `solver`, no `mirror`, signed codes); then, when the check's
        held-back poses were recovered better so, every occluded pose gets the
        mean of that answer and the local ridge's over the base with the
        complete poses as extra atoms
        (:func:`~sparseedm.exemplars.ridge_mean_atoms`); then with a Gaussian's
        answer over the file's poses at a weight the check chooses
        (:func:`~sparseedm.gaussian_fill.local_gaussian_fill`); then, on a
        file of fewer than :data:`~sparseedm.cold_bank.BANK_STEP_MAX_COMPLETE`
        complete poses, with the shipped pose bank's answer at a weight probes
        of the occluded rows choose (0 unless it pays:
        :func:`~sparseedm.cold_bank.bank_step`); and last a
        hidden joint that the file's other rows show is moved toward them
        where probes say so (:func:`~sparseedm.donors.donor_step`). ``False``:
        adapt as described under `adapt` (below MIN_COMPLETE_POSES: the base
        with the complete poses as extra atoms), no blend.
        ``res.adaptation.summary()["path"]`` says which ran.
    mirror : {False, True, "auto"}, optional
        Default ``"auto"`` with ``adapt=False`` and no `dictionary` (poses
        coded one by one), else False.
        (sparse method, per pose) Also code each pose's mirror image (left and
        right joints swapped: :meth:`~sparseedm.dictionary.Dictionary.mirrored`)
        and return the mean of the two answers, twice the work. It helps where
        the dictionary is not left-right symmetric and the hidden joints are
        uncertain. ``"auto"``: the mirror answer's weight falls from one half
        as its lasso objective exceeds the pose's own
        (:func:`~sparseedm._recovery_base.mirror_weights`): about the mean on
        photos of real people, about the pose's own answer on poses the
        dictionary learned from. With ``adapt=False`` and
        ``dictionary="cmu-coco-k2932"`` it is the default without a
        dictionary (``docs/explanation/settings.md``, "Without
        adaptation"). With an ensemble, every member is mirrored.

    Returns
    -------
    RecoveryResult
        A :class:`~sparseedm.temporal.recover.TemporalResult` (per-joint
        ``source``) when `frames` turned temporal recovery on. With the
        outlier check, ``outliers`` (n, N) says which joints it treated as
        missing (their ``source`` is ``"outlier"``).

    Notes
    -----
    Rotation in the image plane: a dictionary whose ``recovery_scale`` is
    ``"radius"`` (the shipped ones) normalises each pose by its observed
    joints' centroid and RMS radius, which turn with the body, and placement
    is isotropic: a pose rotated about any point gets the same joints filled,
    rotated (to rounding), with ``adapt=False`` and on the file-atoms path
    (the file's complete poses enter as unit-norm EDM vectors, which a
    rotation leaves alone). Not exact: a file that adapts (adaptation learns
    on its complete poses normalised by their bounding box, the training
    rule, and its filters use that box), ``method="fconv"`` (its networks
    were trained on box-normalised inputs) and a dictionary file whose
    ``recovery_scale`` is ``"box"`` (files made before the field). A pose
    whose observed joints are nearly collinear (only the neck and shoulders,
    say) has two mirror placements across their line that fit its distances
    almost equally; which one it gets can flip with rounding, hence with a
    rotation.

    Examples
    --------
    >>> import numpy as np
    >>> import sparseedm
    >>> pose = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78],
    ...                  [65, 32], [70, 55], [72, 78], [40, 80], [40, 115],
    ...                  [40, 150], [60, 80], [60, 115], [60, 150]], float)
    >>> pose[4] = np.nan                      # right wrist occluded
    >>> res = sparseedm.recover(pose)
    >>> res.status.tolist()
    ['recovered']
    >>> bool(np.isfinite(res.poses).all()), bool((res.poses[0, :4] == pose[:4]).all())
    (True, True)
    """
    validate_params("recover", dict(
        dictionary=dictionary, alpha=alpha, representation=representation, solver=solver,
        n_jobs=n_jobs, chunk_size=chunk_size, positive=positive, progress=progress,
        backend=backend, scheduler=scheduler, method=method, self_training=self_training,
        ensemble=ensemble, temporal=temporal, preset=preset, outliers=outliers,
        exemplars=exemplars, mirror=mirror), _PARAMS)
    check_options_apply("recover", method=method, model=model, backend=backend,
                        scheduler=scheduler, adapt=adapt, ensemble=ensemble, preset=preset,
                        self_training=self_training, exemplars=exemplars)
    cold, mirror = cold_prior(dictionary, adapt, mirror,
                              method == "sparse" and (frames is None or not temporal))
    # the cold prior's codes are stacked with the shipped pose bank's answer
    bank, dictionary = cold is not dictionary, cold
    if method != "fconv":  # an FConv model says its own (recover_fconv)
        representation = representation_for(representation)
    if mirror and (method == "fconv" or (frames is not None and temporal)):
        raise ParameterError(f"recover: mirror={mirror!r} averages the sparse answers of each "
                             "pose and its mirror image: it needs method='sparse' and no "
                             "frames (or temporal=False)")
    if frames is not None and temporal:
        if preset == "fast":
            raise ParameterError("recover: preset='fast' recovers each pose on its own: "
                                 "pass temporal=False with frames")
        check_frames(frames, "recover")
    opts = dict(dictionary=dictionary, alpha=alpha, representation=representation,
                solver=solver, n_jobs=n_jobs, chunk_size=chunk_size, positive=positive,
                progress=progress, backend=backend, scheduler=scheduler, adapt=adapt,
                self_training=self_training, ensemble=ensemble, exemplars=exemplars,
                mirror=mirror, cold_bank=bank)
    check_outliers = confidence is not None and outliers
    if method == "sparse" or check_outliers:  # validated once here; the paths below trust them
        if not isinstance(dictionary, Dictionary):
            opts["dictionary"] = dictionary = load_dictionary(dictionary)
        poses, missing, _ = validate_poses(poses, missing, dictionary.n_joints)
        _warn_origin_joints(poses, missing)
    if method == "sparse":
        opts["adapt"] = check_adapt(adapt, "recover", dictionary.n_joints)
    frames = frames if temporal else None
    with _progress.turned_on(progress):  # the long stages say what they do, as in the CLI
        if not check_outliers:
            return _dispatch(poses, missing, tracks, frames, method, model, preset, opts)
        poses, missing, outlier = mark_outliers(
            poses, missing, check_confidence(confidence, missing.shape, "recover"),
            dictionary, tracks=tracks, frames=frames, alpha=alpha,
            representation=representation_for(representation), solver=solver,
            n_jobs=n_jobs, chunk_size=chunk_size, positive=positive)
        return note_outliers(_dispatch(poses, missing, tracks, frames, method, model,
                                       preset, opts), outlier)


def _warn_origin_joints(poses, missing):
    """Warn of observed joints at exactly (0, 0) in pixel poses: many tools write
    ``0, 0`` for a joint they did not find (the file readers read those as
    missing, :func:`sparseedm.keypoints.origin_joints`)."""
    origin = origin_joints(poses, missing)
    if origin.any():
        warnings.warn(
            f"recover: {int(origin.sum())} joint(s) of {int(origin.any(axis=1).sum())} "
            "pose(s) in pixels are at exactly (0, 0) and are taken as observed; if your "
            "tool writes 0, 0 for a joint it did not find, set them to NaN "
            "(poses[sparseedm.keypoints.origin_joints(poses)] = np.nan) or, with a "
            "missing mask, add them to it (missing | origin_joints(poses, missing))",
            UserWarning, stacklevel=3)


def _dispatch(poses, missing, tracks, frames, method, model, preset, opts):
    """recover() once its arguments are checked: in time, FConv or the sparse path."""
    if frames is not None:
        res = _recover_in_time(poses, missing, tracks, frames, method, opts)
        linked = getattr(res, "linked_tracks", None)
        return _with_uncertainty(res, tracks if linked is None else linked, frames)
    if method == "fconv":  # torch is imported only on this path
        from .fconv.recover import recover_fconv

        if opts["ensemble"] > 1:
            raise SparseEDMError("ensemble averages adapted dictionaries: it needs "
                                 "method='sparse'")

        return _with_uncertainty(recover_fconv(
            poses, missing, model=model, representation=opts["representation"],
            chunk_size=opts["chunk_size"], progress=opts["progress"]))
    dictionary, adapt = opts["dictionary"], opts["adapt"]
    check_gram_memory(dictionary)
    adaptations, members = [], [dictionary]
    kernel = {k: opts[k] for k in ("alpha", "representation", "solver", "n_jobs",
                                   "chunk_size", "positive", "progress")}
    with one_client(opts["backend"], opts["scheduler"]) as dist:
        if adapt is not False:
            # one member unless an ensemble was asked for (seed 0 is the default's)
            members, adaptations = adapt_members(
                dictionary, poses, missing, adapt, opts["ensemble"], n_jobs=opts["n_jobs"],
                self_training=opts["self_training"], file_atoms=True, preset=preset,
                exemplars=opts["exemplars"], **dist)
        kernel["solver"] = preset_solver(kernel["solver"], preset,
                                         adaptations[0] if adaptations else None,
                                         kernel["positive"])
        if opts["mirror"]:
            members = [*members, *(m.mirrored() for m in members)]
        where = dist or dict(backend=opts["backend"], scheduler=opts["scheduler"])
        res = recover_members(poses, missing, members, adaptations,
                              mirror_gate=opts["mirror"] == "auto", **kernel,
                              check_input=False, **where)
        if opts["cold_bank"]:
            res = cold_bank_stack(res, poses, missing)
        if adaptations and blends(opts["adapt"], opts["exemplars"], preset, opts["mirror"],
                                  opts["solver"], opts["positive"]):
            atoms = blend_parts(dictionary, poses, missing, adaptations[0])
            res = blend_many_hidden(res, poses, missing, *atoms, **where,
                                    **{k: kernel[k] for k in BLEND_SETTINGS})

            def answer_for(parts):  # the same path's answer for other rows (the probes)
                def answer(p, m):
                    r = recover_members(p, m, members, adaptations, **kernel,
                                        check_input=False, **where)
                    return blend_many_hidden(r, p, m, *parts, **where,
                                             **{k: kernel[k] for k in BLEND_SETTINGS})
                return answer

            res = finish_blend(res, poses, missing, answer_for, atoms, bank=bank_step)
    return _with_uncertainty(res)


def _with_uncertainty(res, tracks=None, frames=None):
    """`res` with its calibrated 90 % radius per joint (:mod:`sparseedm.uncertainty`)."""
    res.uncertainty = joint_uncertainty(res, tracks, frames)
    return res


def _recover_in_time(poses, missing, tracks, frames, method, kwargs):
    """recover(frames=...): the temporal model (:mod:`sparseedm.temporal`)."""
    if method != "sparse":
        raise SparseEDMError("temporal recovery uses the sparse method: pass "
                             "method='sparse', or temporal=False")
    kwargs = {k: v for k, v in kwargs.items()
              if k not in ("exemplars", "mirror", "cold_bank")}  # per pose only
    return recover_temporal(poses, missing, tracks=tracks, frames=frames, check_input=False,
                            **kwargs)


class OcclusionRecoverer:
    """scikit-learn-style shell around :func:`recover`.

    ``__init__`` only stores the arguments; :meth:`fit` loads the dictionary
    (``dictionary_``); :meth:`transform` returns filled poses and keeps the
    last :class:`RecoveryResult` in ``result_``.

    Parameters
    ----------
    dictionary : Dictionary, str or path, optional
        As :func:`recover`'s: None means the shipped default, and
        ``cmu-coco-k2932`` with ``mirror="auto"`` when ``adapt=False``.
    alpha : float, optional
        Lasso penalty; default the dictionary's recommended ``alpha_recover``.
    representation : {"average", "zero"}, optional
        How occluded joints enter the EDM vector; default ``"average"``.
    solver : {"fast", "clarabel", "cvxpy-naive"} or a BaseSolver, default "fast"
        As :func:`recover`'s.
    n_jobs : int, default 1
        joblib workers over chunks of poses; -1 for all cores.
    adapt : "auto", False or array_like (n_adapt, N, 2), default "auto"
        As :func:`recover`'s: ``"auto"`` adapts the dictionary on the complete
        poses given to :meth:`transform` when there are enough of them.
    mirror : {False, True, "auto"}, optional
        As :func:`recover`'s: also code each pose's mirror image and average
        the two answers (``"auto"``: weighed by their lasso objectives; the
        default with ``adapt=False`` and no `dictionary`, else False).

    Examples
    --------
    >>> import numpy as np
    >>> pose = np.array([[50, 10], [50, 30], [35, 32], [30, 55], [28, 78],
    ...                  [65, 32], [70, 55], [72, 78], [40, 80], [40, 115],
    ...                  [40, 150], [60, 80], [60, 115], [60, 150]], float)[None]
    >>> pose[0, 12] = np.nan                   # left knee occluded
    >>> filled = OcclusionRecoverer().fit().transform(pose)
    >>> filled.shape, bool(np.isfinite(filled).all())
    ((1, 14, 2), True)
    """

    def __init__(self, dictionary=None, *, alpha=None, representation=None,
                 solver="fast", n_jobs=1, adapt="auto", mirror=None):
        self.dictionary = dictionary
        self.mirror = mirror
        self.alpha = alpha
        self.adapt = adapt
        self.representation = representation
        self.solver = solver
        self.n_jobs = n_jobs

    def fit(self, X=None, y=None):
        """Load the dictionary (nothing is learned from X).

        Parameters
        ----------
        X : array_like, optional
            Ignored: present for scikit-learn's ``fit(X, y)`` convention.
        y : None
            Ignored.

        Returns
        -------
        OcclusionRecoverer
            This estimator, with ``dictionary_`` and ``mirror_`` (the rule
            :meth:`transform` uses) set.

        Raises
        ------
        ParameterError
            An argument given to ``__init__`` is out of its range.
        """
        validate_params("OcclusionRecoverer", dict(
            dictionary=self.dictionary, alpha=self.alpha, representation=self.representation,
            solver=self.solver, n_jobs=self.n_jobs, mirror=self.mirror),
            {k: _PARAMS[k] for k in ("dictionary", "alpha", "representation", "solver",
                                     "n_jobs", "mirror")})
        d, self.mirror_ = cold_prior(self.dictionary, self.adapt, self.mirror)
        self.dictionary_ = d if isinstance(d, Dictionary) else load_dictionary(d)
        return self

    def transform(self, X, missing=None):
        """Filled poses (n, N, 2); NaN coordinates (or `missing`) mark occlusions.

        Calls :meth:`fit` first when it was not called.

        Parameters
        ----------
        X : array_like, shape (n, N, 2) or (N, 2)
            Keypoints in the caller's own pixel frame.
        missing : array_like of bool, shape (n, N), optional
            True where a joint is occluded; by default NaN coordinates mark them.

        Returns
        -------
        ndarray (n, N, 2)
            The poses with their occluded joints filled (NaN where a pose was
            refused: ``result_.status`` says why); the whole
            :class:`RecoveryResult` is kept in ``result_``.
        """
        if not hasattr(self, "dictionary_"):
            self.fit()
        # no dictionary given: recover()'s own (with adapt=False, the cold prior and its bank)
        given = self.dictionary_ if self.dictionary is not None else None
        self.result_ = recover(X, missing, dictionary=given, alpha=self.alpha,
                               representation=self.representation, solver=self.solver,
                               n_jobs=self.n_jobs, adapt=self.adapt, mirror=self.mirror_)
        return self.result_.poses
