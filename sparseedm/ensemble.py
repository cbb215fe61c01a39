"""Ensembles of adapted dictionaries (beyond the paper).

An adapted dictionary depends on its seed: which complete poses are held back
for the guard, the order of the mini-batches, the self-training sample. On
the validation clips of ``studies/adaptation/select_adaptation.py`` (three
cross-source directions, 400 Mix poses each) one seed's Mix Err_ave moved by
3-7 % from the next. ``recover(..., ensemble=K)`` therefore adapts K times
(seeds 0 .. K-1), recovers the poses with each member and returns the mean
of the members' filled poses (observed joints as given) and of their
completed EDM vectors. On those validation clips five members lowered the
filled-pose error by 4-8 % against seed 0 alone; averaging the members' atoms
instead (one dictionary) made it 15 % worse, a union of three members' atoms
5 % worse. It costs K adaptations and K recoveries, so it is off by default
(``ensemble=1``). With ``n_jobs`` > 1 the members after the first adapt side
by side, one thread each (the same atoms as one after the other).

Only adapted members are worth averaging: when the first adaptation is not
adopted (too few complete poses, or the guard keeps the base dictionary) the
ensemble stops at that one member. When the default path takes the file's own
complete poses as the atoms (:mod:`sparseedm.exemplars`) nothing is learned,
so every seed would code with the same atoms: the ensemble stops at that
path's own dictionaries (one, or the three whose answers it averages). Either
way a ``UserWarning`` says why, and the result's adaptation records the
members asked and those that ran (``settings["ensemble"]``, in its
``summary()``).
"""

from __future__ import annotations

import warnings
from dataclasses import replace

from joblib import Parallel, delayed, effective_n_jobs
from threadpoolctl import threadpool_limits

from . import _progress
from .adaptation import MIN_COMPLETE_POSES, resolve_adaptation
from .exemplars import choose_exemplars
from .file_atoms import resolve_fast, with_file_atoms
from ._recovery_base import combine
from ._recovery_kernel import FAST_MAX_ATOMS

__all__ = ["adapt_members", "combine"]


def adapt_members(dictionary, poses, missing, adapt, n_members, *, n_jobs=1,
                  self_training=None, warn=True, min_poses=MIN_COMPLETE_POSES,
                  file_atoms=False, preset="default", exemplars=False, backend=None,
                  scheduler=None, check_input=True):
    """Dictionaries adapted with seeds 0 .. n_members - 1, and what each did.

    Parameters
    ----------
    dictionary : Dictionary
    poses, missing : ndarray
        As :func:`sparseedm.adaptation.resolve_adaptation` takes them.
    adapt : "auto" or array_like
    n_members : int
        At least 1.
    n_jobs, self_training, warn, min_poses, check_input
        As :func:`sparseedm.adaptation.resolve_adaptation` (`min_poses`: as
        :func:`~sparseedm.adaptation.run_adaptation`).
    file_atoms : bool, default False
        When the first adaptation is not adopted, append the complete poses
        it was offered to the base dictionary as atoms
        (:func:`sparseedm.file_atoms.with_file_atoms`; the result's
        ``file_atoms`` counts them). :func:`sparseedm.recover` and
        :func:`sparseedm.batch.recover_file` pass True.
    preset : {"default", "fast"}, default "default"
        ``"fast"``: no adaptation; the complete poses offered become the
        atoms (:func:`sparseedm.file_atoms.resolve_fast`; at most
        :data:`sparseedm._recovery_kernel.FAST_MAX_ATOMS`), one member.
    exemplars : {"auto", False}, default False
        ``"auto"`` (with ``adapt="auto"``): the file's complete poses as the
        only atoms, nothing learned, when
        :func:`sparseedm.exemplars.choose_exemplars` picks them (one member,
        or its :attr:`~sparseedm.exemplars.ExemplarCheck.members` when it
        averages).
        :func:`sparseedm.recover` and :func:`sparseedm.batch.recover_file`
        pass their own (``"auto"`` by default); the video path does not.
    backend, scheduler : optional
        As :func:`sparseedm.recover`'s: ``backend="dask"`` runs every member's
        guard and self-training recoveries on the cluster (the learning stays
        in this process).

    Returns
    -------
    dictionaries : list of Dictionary
        The adopted members; only the base dictionary when the first (seed 0)
        adaptation was not adopted.
    adaptations : list of AdaptationResult
        One per dictionary (one for the exemplars' path); empty when `adapt`
        asks for none (False or None, as
        :func:`~sparseedm.adaptation.resolve_adaptation` reads it). With
        `n_members` > 1 the first records ``settings["ensemble"]``: the
        members ``asked`` and the dictionaries returned (``members``).

    Warns
    -----
    UserWarning
        `n_members` > 1 when the first adaptation is not adopted or the
        exemplars are chosen: why, and how many dictionaries recover.
    """
    if preset == "fast":
        d, res = resolve_fast(dictionary, poses, missing, adapt, min_poses=min_poses,
                              max_atoms=FAST_MAX_ATOMS)
        return [d], ([] if res is None else [res])
    check = None
    if exemplars == "auto" and isinstance(adapt, str) and adapt == "auto":
        check = choose_exemplars(dictionary, poses, missing,
                                 n_jobs=None if n_jobs == 1 else n_jobs, backend=backend,
                                 scheduler=scheduler)
        if check.dictionary is not None:  # nothing learned: every seed's atoms the same
            return check.members, [_short(check.members, check.result, n_members,
                                          f"the file's own complete poses are the atoms "
                                          f"({check.result.reason}): every seed would code "
                                          "with the same atoms")]
    # the work is many small BLAS calls beside numba's threads: BLAS threads
    # would only spin against them (measured 2x slower), so BLAS gets one. Held
    # here for every member: the members' guards' recover() calls set and
    # restore the limit, out of order across the threads below.
    with threadpool_limits(1, user_api="blas"):
        # n_jobs=1 runs in this thread: its compiled loops (learning, guard,
        # self-training) use numba's threads, as recover()'s kernel does (None
        # below); a one-thread cap is for the side-by-side members further down
        d, res = resolve_adaptation(dictionary, poses, missing, adapt,
                                    n_jobs=None if n_jobs == 1 else n_jobs,
                                    random_state=0, warn=warn, self_training=self_training,
                                    min_poses=min_poses, backend=backend,
                                    check_input=check_input,
                                    scheduler=scheduler)
        if res is None:  # adaptation off
            return [d], []
        if file_atoms and not res.adapted:
            d, res = _file_atoms(dictionary, poses, missing, adapt, res)
        if check is not None:  # what the check found, beside what adapting did
            res = check.note(res)
        dictionaries, adaptations = [d], [res]
        if int(n_members) <= 1 or not res.adapted:  # seed 0 not adopted: too few, or base better
            return dictionaries, [_short(dictionaries, res, n_members,
                                         f"seed 0's adaptation was not adopted ({res.reason}): "
                                         "only adapted dictionaries are averaged")]
        more = int(n_members) - 1
        _progress.say(f"ensemble: adapting {more} more "
                      + ("dictionary (seed 1)" if more == 1 else f"dictionaries (seeds 1..{more})"))
        # The other seeds side by side, one thread each: a member's own steps use a
        # second thread poorly (1.2x), two members at once ran 1.37x faster than one
        # after the other with 2 threads, with bit-identical atoms (2 cores, 400 poses).
        workers = max(1, min(effective_n_jobs(n_jobs), int(n_members) - 1))
        # the members' own catch_warnings interleave across threads: held here, restored
        with warnings.catch_warnings():
            rest = Parallel(n_jobs=workers, backend="threading")(
                delayed(resolve_adaptation)(dictionary, poses, missing, adapt,
                                            n_jobs=1 if workers > 1 else n_jobs,
                                            random_state=seed, warn=False,
                                            self_training=self_training,
                                            min_poses=min_poses, backend=backend,
                                            check_input=check_input,
                                            scheduler=scheduler)
                for seed in range(1, int(n_members)))
    for seed, (d, res) in enumerate(rest, start=1):
        if res is not None and res.adapted:  # else this seed's guard kept the base:
            dictionaries.append(d)           # not a member to average
            adaptations.append(res)
        else:
            _progress.say(f"ensemble: member seed {seed} dropped: "
                          f"{res.reason if res is not None else 'not adapted'}")
    adaptations[0] = _asked(adaptations[0], n_members, len(dictionaries))
    return dictionaries, adaptations


def _asked(res, n_members, n_ran):
    """`res` recording, when an ensemble was asked for, the members asked and
    the dictionaries that recover (its ``settings["ensemble"]``)."""
    if int(n_members) <= 1:
        return res
    return replace(res, settings=dict(res.settings, ensemble={"asked": int(n_members),
                                                              "members": int(n_ran)}))


def _short(dictionaries, res, n_members, why):
    """`res` with the ensemble's record (:func:`_asked`); when more members were
    asked for than the path fits, a warning saying `why` and what recovers."""
    if int(n_members) <= 1:
        return res
    n = len(dictionaries)
    what = ("1 dictionary recovers" if n == 1 else
            f"the mean of {n} dictionaries' answers, the path's own, recovers")
    warnings.warn(f"ensemble={int(n_members)}: {why}; {what}, not {int(n_members)} "
                  "members", UserWarning, stacklevel=4)
    return _asked(res, n_members, n)


def _file_atoms(dictionary, poses, missing, adapt, res):
    """The base with the offered complete poses as atoms, and `res` saying so."""
    source = (poses, missing) if isinstance(adapt, str) else (adapt, None)
    found = with_file_atoms(dictionary, *source)
    if not found.n_atoms:
        return res.dictionary, res
    return found.dictionary, replace(res, dictionary=found.dictionary,
                                     file_atoms=found.n_atoms)
