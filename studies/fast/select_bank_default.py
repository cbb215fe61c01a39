"""The shipped pose bank in the default path's stacked mean.

The default path's stacked mean averages every occluded pose's answer with the
conditional mean of a local Gaussian
(:func:`sparseedm.gaussian_fill.local_gaussian_fill`) whose draws are the
file's poses and their mirror images (``exemplars._linear_draws``), weighted
by the held-back check (``linear_weight``) or, below 50 complete poses, by
probes (``probe_stack``). ``recover(adapt=False)`` stacks its codes with
the same Gaussian over a shipped bank of poses instead
(:func:`sparseedm.cold_bank.bank_fill`). Variants of the default path, each
replacing every ``local_gaussian_fill`` call of ``exemplars`` (the stacked
mean, the check's weight and the probes' alike):

* ``add gate``: the bank's poses, turned so that their mean body axis is the
  draws' (:func:`sparseedm.file_atoms.body_axis`), added to the file's draws;
  a pose nearer the bank's photographed people than its motion capture (the
  gate of ``bank_fill``) gets the photographed part alone added, any other the
  whole bank;
* ``add coco``: the bank's photographed part alone added for every pose;
* ``avg``: the mean of the file's Gaussian's fill and ``bank_fill``'s (a third
  candidate averaged in);
* ``few bank``: ``bank_fill`` in place of the file's Gaussian on files with
  fewer than 50 complete poses (``probe_stack``'s files; others the shipped
  defaults).

End to end: ``recover()``'s defaults with the variant against the shipped
defaults (cached per file), II (IterativeImputer) beside them (taken from
``select_local_align.py``'s cache when there). Files:
``select_local_align.py``'s (validation photo files of
``benchmarks/real_people.py``: MPII val 200 + 199, COCO val 28 + 27, Bonn val
frames, each also with 1,000 (COCO 233) train complete poses; mix = 1-3
random hidden joints, transplanted = real masks) and, with ``--few C+M``,
``select_few_stack.py``'s (C complete + M occluded of the val split). Score:
per occluded pose the mean error of its hidden joints, % of body size; paired
differences [mean, standard error].

    python studies/fast/select_bank_default.py --seeds 0,1,2 --variant "add gate" \\
        --out selection_bank_default_add_gate.json
    python studies/fast/select_bank_default.py --seeds 0,1,2 --variant "few bank" --few 28+200,40+200 \\
        --out selection_bank_default_few_bank.json
    python studies/fast/select_bank_default.py --table selection_bank_default_add_gate.json

(``add coco`` and ``avg`` likewise, with ``--few`` or without; ``few bank`` with
``--sources coco`` and with ``--few``.)
"""

from __future__ import annotations

import argparse
import contextlib
import sys
from functools import partial
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

CACHE = Path("/tmp/photos_bankdef/cache")
#: select_local_align.py's cache: its II answers are reused (the same files)
ALIGN_CACHE = Path("/tmp/photos_align/cache")

VARIANTS = ("add gate", "add coco", "avg", "few bank")


def _turned_bank(train):
    """The bank's poses turned so that their mean body axis is `train`'s, and
    which are photographed."""
    from sparseedm.cold_bank import load_pose_bank
    from sparseedm.file_atoms import body_axis

    bank = load_pose_bank()
    draws = bank.poses
    own, theirs = body_axis(draws), body_axis(train)
    if own is not None and theirs is not None:
        c, s = own @ theirs, own[0] * theirs[1] - own[1] * theirs[0]
        draws = draws @ np.array([[c, -s], [s, c]]).T
    return draws, bank.photographed


def bank_added_fill(train, poses, missing, *, gate=True, **kw):
    """local_gaussian_fill's signature over `train` and the bank's poses (the
    photographed part alone where the gate says so, or everywhere with
    ``gate=False``)."""
    from sparseedm.cold_bank import COLD_BANK_GATE, COLD_BANK_GATE_NEIGHBOURS
    from sparseedm.gaussian_fill import local_gaussian_fill, nearest_distances

    draws, photo = _turned_bank(train)
    near = np.ones(len(poses), bool)
    if gate:
        dist = nearest_distances(draws, poses, missing, COLD_BANK_GATE_NEIGHBOURS, photo)
        with np.errstate(invalid="ignore"):
            near = dist[:, 0] < COLD_BANK_GATE * dist[:, 1]
    out = np.array(poses, dtype=float)
    for rows, pool in ((near, draws[photo]), (~near, draws)):
        if rows.any():
            out[rows] = local_gaussian_fill(np.concatenate([train, pool]), poses[rows],
                                            missing[rows], **kw)
    return out


def averaged_fill(train, poses, missing, **kw):
    """The mean of the file's Gaussian's fill and bank_fill's (NaN of one: the other)."""
    from sparseedm.cold_bank import bank_fill, load_pose_bank
    from sparseedm.gaussian_fill import local_gaussian_fill

    a = local_gaussian_fill(train, poses, missing, **kw)
    b = bank_fill(load_pose_bank(), poses, missing)
    return np.where(np.isfinite(a) & np.isfinite(b), (a + b) / 2,
                    np.where(np.isfinite(a), a, b))


def bank_only_fill(train, poses, missing, **kw):
    """bank_fill in local_gaussian_fill's place (`train` unused)."""
    from sparseedm.cold_bank import bank_fill, load_pose_bank

    return bank_fill(load_pose_bank(), poses, missing)


FILLS = {"add gate": bank_added_fill, "add coco": partial(bank_added_fill, gate=False),
         "avg": averaged_fill, "few bank": bank_only_fill}


@contextlib.contextmanager
def patched(variant):
    """recover()'s defaults with the variant's fill in exemplars' local_gaussian_fill."""
    import sparseedm.exemplars as ex

    kept = ex.local_gaussian_fill
    ex.local_gaussian_fill = FILLS.get(variant, kept)  # "shipped": as it is
    try:
        yield
    finally:
        ex.local_gaussian_fill = kept


def measure(name, truth, missing, photo, kw, variant):
    """One file end to end (``select_local_average.measure`` with this study's
    fills and cache): per-pose errors of the shipped defaults (cached), II
    (photos) and the variant; weights; seconds. ``few bank`` on a file with 50
    complete poses or more: the shipped defaults run again."""
    import studies.fast.select_local_average as avg

    avg.CACHE, avg.ALIGN_CACHE, avg.patched = CACHE, ALIGN_CACHE, patched
    if variant == "few bank" and (~missing.any(axis=1)).sum() >= 50:
        variant = "shipped"
    return avg.measure(name, truth, missing, photo, kw, variant)


def few_files(few):
    """select_local_gaussian.files' signature over select_few_stack.py's files
    (`few`: "C+M,...", C complete + M occluded of the val split; the COCO val
    file whole is the main files')."""
    from studies.fast.select_few_stack import _sizes, files

    def listed(sources, parts, mocap, mocap_sizes, seed):
        for item in files(sources, ("mix", "transplanted"), _sizes(few), "", [], seed):
            if not item[0].startswith("coco"):
                yield item
    return listed


def main(argv=None):
    import studies.fast.select_local_gaussian as gaussian
    from studies.fast.select_local_align import options, run

    ap = options(argparse.ArgumentParser(description=__doc__.splitlines()[0]),
                 "", "add gate")
    ap.add_argument("--few", default="", help="C+M,...: select_few_stack.py's files instead")
    ap.add_argument("--out", type=Path, default=Path("bank_default.json"))
    a = ap.parse_args(argv)
    if a.few:  # run() reads its files from select_local_gaussian
        gaussian.files = few_files(a.few)
    run(a, None, measure)


if __name__ == "__main__":
    main()
