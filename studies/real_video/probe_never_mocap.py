"""Motion capture with joints hidden for a whole sequence: ``never_mirror`` on and off.

The motion-capture protocols of ``select_prior.py`` never hide a joint in every
frame, so ``TemporalSettings.never_mirror`` leaves them unchanged. This probe
gives the case it acts on: each of the first N validation sequences per source
(``benchmarks.video_protocols``, the source's dictionary), as given and (CMU)
with 1 % white jitter, with 1-2 seeded limb joints (elbows, wrists, knees,
ankles) hidden in every frame, plus the gaps protocol's mask; the error of the
never-seen joints (% of body height) with and without the gate::

    nice python studies/real_video/probe_never_mocap.py --mocap 8 \\
        --out studies/real_video/probe_never_mocap.json

Validation only; nothing of Bandai-Namco is written but scores.
"""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(ROOT))

from benchmarks import video_protocols  # noqa: E402
from sparseedm.dictionary import load_dictionary  # noqa: E402
from sparseedm.metrics import joint_error  # noqa: E402
from sparseedm.temporal.evaluation import detector_jitter  # noqa: E402
from sparseedm.temporal.model import DEFAULT_SETTINGS  # noqa: E402
from sparseedm.temporal.recover import recover_temporal  # noqa: E402
from studies.real_video.select_fusion import emit  # noqa: E402
from studies.temporal.probe_one_clip_guard import mocap_cases  # noqa: E402

LIMBS = (3, 4, 6, 7, 9, 10, 12, 13)
ARMS = {"off": replace(DEFAULT_SETTINGS, never_mirror=False),
        "on": replace(DEFAULT_SETTINGS, never_mirror=True)}


def run(max_sequences, jitter=0.01):
    """{source kind: {arm: [never-seen error, all hidden error]} means} and seconds."""
    out, seconds = {}, {}
    for source in ("cmu", "bandai"):
        dictionary = load_dictionary(video_protocols.DICTIONARY[source])
        for i, seq, protocol, _, mask, _ in mocap_cases(source, max_sequences):
            if protocol != "gaps":
                continue
            rng = np.random.default_rng(i)
            never = rng.choice(LIMBS, size=1 + i % 2, replace=False)
            mask = mask.copy()
            mask[:, never] = True
            truth = seq.poses2d
            kinds = {"as given": truth}
            if source == "cmu":
                kinds["jitter"] = truth + detector_jitter(seq, jitter, random_state=i)
            for kind, poses in kinds.items():
                given = np.where(mask[..., None], np.nan, poses)
                for name, settings in ARMS.items():
                    t0 = time.perf_counter()
                    with warnings.catch_warnings():
                        warnings.simplefilter("ignore")
                        filled = recover_temporal(given, mask, frames=seq.frames,
                                                  dictionary=dictionary,
                                                  settings=settings).poses
                    key = f"{source} {kind}"
                    seconds[f"{key} {name}"] = seconds.get(f"{key} {name}", 0.0) + (
                        time.perf_counter() - t0)
                    err = joint_error(filled, truth, mask) / seq.height * 100
                    cols = np.zeros_like(mask)
                    cols[:, never] = True
                    out.setdefault(key, {}).setdefault(name, []).append(
                        [float(np.nanmean(err[cols])), float(np.nanmean(err[mask & ~cols]))])
    return ({k: {n: np.round(np.mean(v, axis=0), 4).tolist() for n, v in arms.items()}
             for k, arms in out.items()},
            {k: round(v, 2) for k, v in seconds.items()})


def main(argv=None):
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--mocap", type=int, default=8)
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    errors, seconds = run(args.mocap)
    emit(dict(split="validation", columns=["never seen", "other hidden"], errors=errors,
              seconds=seconds), args.out)


if __name__ == "__main__":
    main()
