"""Training FConv networks: seeded Adam on mini-batches, early stopping by clip.

Two tasks share one training loop (:func:`fit_network`):

* :func:`fit_fconv` -- the paper's recovery network: the input is the
  occluded pose's EDM vector under the 'zero' or 'average' representation,
  built by :func:`sparseedm.normalize.represent` exactly as the sparse path
  builds it; the target is the complete pose's EDM in the same normalisation
  (the observed joints' bounding box), so its output is read as the sparse
  path's recovered vector is. Every epoch draws fresh masks of 1-3 occluded
  joints per pose (the protocol's Mix).
* :func:`fit_edm_lifter` (formerly ``fit_lifter``, deprecated) -- DMR's 2D -> 3D regression with the same network: the
  input is the 2D EDM (optionally occluded, same representations), the target
  the 3D pose's EDM in metres.

Validation rows are whole clips (every 5th clip in sorted order from the 3rd,
the split ``studies/dictionary/select_alpha.py`` and the benchmarks use), with masks
drawn once; the parameters of the epoch with the lowest validation loss are
kept; training stops after ``patience`` epochs without a relative improvement
of ``tol``. CPU by default; ``device="cuda"`` when asked.
"""

from __future__ import annotations

import time

import numpy as np

from .. import _progress
from .._deprecated import alias_getattr
from .._validation import Options, check_pose_shape, validate_params
from ..edm import pose_to_vector, triu_indices
from ..exceptions import PoseError, SparseEDMError
from ..metrics import random_occlusion
from ..normalize import REPRESENTATIONS, represent
from ..skeleton import JOINT_NAMES
from .model import FConvModel, to_matrix
from .network import build_network, require_torch
from .recover import recover_fconv

__all__ = ["fit_fconv", "fit_edm_lifter", "split_by_clip", "occlusion_range", "FConvRecoverer"]


def split_by_clip(clips, n_poses, random_state=0):
    """Validation mask: every 5th clip in sorted order from the 3rd.

    Without clip names (``clips=None``), or with fewer than 3 clips, a seeded
    10 % of the rows is used instead (said in the model's metadata).

    Parameters
    ----------
    clips : array_like of str, shape (n_poses,), or None
        The clip each pose comes from.
    n_poses : int
        Number of poses (rows) to split.
    random_state : int, default 0
        Seed of the row split used when there are no clip names or fewer than
        3 clips.

    Returns
    -------
    mask : ndarray of bool, shape (n_poses,)
        True for the validation rows.
    description : str
        How the split was made, for the model's metadata.

    Examples
    --------
    >>> import numpy as np
    >>> clips = np.array(["a", "a", "b", "c", "c", "d"])
    >>> split_by_clip(clips, 6)[0].tolist()
    [False, False, False, True, True, False]
    """
    if clips is not None:
        clips = np.asarray(clips).astype(str)
        if clips.shape != (n_poses,):
            raise PoseError(f"clips must have shape ({n_poses},), got {clips.shape}")
        names = sorted(set(clips.tolist()))
        if len(names) >= 3:
            held = [c for i, c in enumerate(names) if i % 5 == 2]
            return np.isin(clips, held), f"by clip: {len(held)} of {len(names)} clips held out"
    rng = np.random.default_rng([int(random_state), 7])
    val = np.zeros(n_poses, dtype=bool)
    val[rng.choice(n_poses, max(1, n_poses // 10), replace=False)] = True
    return val, "by row: no clip names (or fewer than 3 clips), a seeded 10 % of the poses"


def occlusion_range(n_poses, n_joints, occluded, rng):
    """Masks with a uniform count of occluded joints in ``occluded = (lo, hi)``.

    Examples
    --------
    >>> m = occlusion_range(6, 14, (1, 3), np.random.default_rng(0))
    >>> m.shape, set(m.sum(axis=1).tolist()) <= {1, 2, 3}
    ((6, 14), True)
    """
    lo, hi = (int(k) for k in occluded)
    if not 0 <= lo <= hi <= n_joints - 3:
        raise SparseEDMError(f"occluded={occluded!r}: need 0 <= lo <= hi <= {n_joints - 3}")
    counts = rng.integers(lo, hi + 1, size=n_poses)
    mask = np.zeros((n_poses, n_joints), dtype=bool)
    for k in range(lo, hi + 1):
        rows = np.flatnonzero(counts == k)
        mask[rows] = random_occlusion(len(rows), n_joints, k, random_state=rng)
    return mask


def _check_training_poses(poses, name, dim, batch_size):
    poses = np.asarray(poses, dtype=float)
    check_pose_shape(poses, name, dim=dim)
    bad = ~np.isfinite(poses).all(axis=(1, 2))
    if bad.any():
        rows = np.flatnonzero(bad)
        raise PoseError(f"{name}: {len(rows)} pose(s) hold NaN or inf (first row {rows[0]}); "
                        "training needs complete poses")
    flat = np.ptp(poses, axis=1).max(axis=1) <= 0
    if flat.any():
        raise PoseError(f"{name}: pose {int(np.flatnonzero(flat)[0])} has all joints coinciding")
    if batch_size < 1:
        raise SparseEDMError(f"batch_size must be >= 1, got {batch_size}")
    return poses


def _recover_pairs(poses, mask, representation):
    """(input, target) EDM vectors of the recovery task for one set of masks."""
    X, center, scale = represent(poses, mask, representation)
    target = pose_to_vector((poses - center[:, None, :]) / scale[:, None, None])
    return X, target


def fit_fconv(poses2d, clips=None, *, representation="average", occluded=(1, 3),
              channels=(32, 64), kernel=3, symmetrize=False, batch_size=256,
              max_epochs=30, patience=4, tol=1e-3, learning_rate=1e-3, random_state=0,
              device="cpu", progress=False, max_train=None, provenance=None):
    """Train the paper's FConv recovery network on complete 2D poses.

    Parameters
    ----------
    poses2d : array_like (n, N, 2)
        Complete training poses (any pixel frame; each is normalised).
    clips : array_like of str (n,), optional
        Clip of each pose: validation holds out whole clips.
    representation : {"average", "zero"}
    occluded : (int, int), default (1, 3)
        Each pose draws its count of occluded joints uniformly from this
        range, afresh every epoch.
    channels, kernel, symmetrize
        The architecture (:mod:`sparseedm.fconv.network`).
    batch_size, max_epochs, patience, tol, learning_rate
        Adam on mini-batches of the training rows; stop after `patience`
        epochs whose validation loss is not ``(1 - tol)`` below the best.
    random_state : int
        Seeds the initial weights, the masks and the batch order.
    device : str, default "cpu"
        A torch device ("cuda" when asked).
    progress : bool
        tqdm bar over epochs (ETA, losses).
    max_train : int, optional
        Keep a seeded subsample of this many training rows.
    provenance : dict, optional
        Stored in the model file's meta.

    Returns
    -------
    FConvModel

    Examples
    --------
    >>> import numpy as np
    >>> rng = np.random.default_rng(0)
    >>> poses = rng.normal(size=(64, 14, 2))
    >>> model = fit_fconv(poses, representation="zero", channels=(4, 8),
    ...                   batch_size=16, max_epochs=2)
    >>> model.kind, model.representation, model.meta["training"]["epochs"]
    ('recover', 'zero', 2)
    """
    check_representation(representation)
    poses = _check_training_poses(poses2d, "training poses", 2, batch_size)
    N = poses.shape[1]

    def pairs(rows, rng):
        return _recover_pairs(poses[rows], occlusion_range(len(rows), N, occluded, rng),
                              representation)

    meta = {"kind": "recover", "occluded": list(occluded)}
    return fit_network(pairs, len(poses), N, clips, meta, representation=representation,
                        channels=channels, kernel=kernel, symmetrize=symmetrize,
                        batch_size=batch_size, max_epochs=max_epochs, patience=patience,
                        tol=tol, learning_rate=learning_rate, random_state=random_state,
                        device=device, progress=progress, max_train=max_train,
                        provenance=provenance)


def fit_edm_lifter(poses2d, poses3d, clips=None, *, representation="average", occluded=(0, 0),
               channels=(32, 64), kernel=3, symmetrize=False, batch_size=256, max_epochs=30,
               patience=4, tol=1e-3, learning_rate=1e-3, random_state=0, device="cpu",
               progress=False, max_train=None, provenance=None):
    """Train the 2D -> 3D EDM network (DMR's regression) with the FConv layers: an
    FConvModel mapping 2D poses to 3D EDM vectors (not a :class:`~sparseedm.lifting.Lifter`;
    ``sparseedm.lifting.fit_lifter(method="fconv")`` wraps this network into one).

    The input is the 2D pose's EDM vector (normalised, under `representation`,
    with 0 occluded joints by default, or a fresh count from `occluded` per
    pose and epoch); the target the 3D pose's EDM vector in its own units
    (metres for :mod:`sparseedm.dataset` files). :func:`sparseedm.fconv.lift_edm_vectors`
    applies the result. Other parameters as :func:`fit_fconv`.

    Parameters
    ----------
    poses2d : array_like (n, N, 2)
        Complete 2D training poses.
    poses3d : array_like (n, N, 3)
        The same poses in 3D.
    clips : array_like of str (n,), optional
        Clip of each pose: validation holds out whole clips.
    representation : {"average", "zero"}
        How occluded joints enter the network.
    occluded : (int, int), default (0, 0)
        Range of occluded joints drawn per pose and epoch.
    channels, kernel, symmetrize
        The architecture (:mod:`sparseedm.fconv.network`).
    batch_size, max_epochs, patience, tol, learning_rate
        As :func:`fit_fconv`.
    random_state : int
        Seeds the weights, the masks and the batch order.
    device : str
        A torch device.
    progress : bool
        tqdm bar over epochs.
    max_train : int, optional
        Keep a seeded subsample of this many training rows.
    provenance : dict, optional
        Stored in the model file's meta.

    Returns
    -------
    FConvModel
        ``kind == "lift"``.
    """
    check_representation(representation)
    p2 = _check_training_poses(poses2d, "training 2D poses", 2, batch_size)
    p3 = _check_training_poses(poses3d, "training 3D poses", 3, batch_size)
    if p2.shape[:2] != p3.shape[:2]:
        raise PoseError(f"2D poses {p2.shape} and 3D poses {p3.shape} do not pair up")
    N = p2.shape[1]
    target3d = pose_to_vector(p3)

    def pairs(rows, rng):
        mask = occlusion_range(len(rows), N, occluded, rng)
        return represent(p2[rows], mask, representation)[0], target3d[rows]

    meta = {"kind": "lift", "occluded": list(occluded), "output_units": "3D pose units (metres)"}
    return fit_network(pairs, len(p2), N, clips, meta, representation=representation,
                        channels=channels, kernel=kernel, symmetrize=symmetrize,
                        batch_size=batch_size, max_epochs=max_epochs, patience=patience,
                        tol=tol, learning_rate=learning_rate, random_state=random_state,
                        device=device, progress=progress, max_train=max_train,
                        provenance=provenance)



def check_representation(representation):
    if representation not in REPRESENTATIONS:
        raise SparseEDMError(f"unknown representation {representation!r}; use one of "
                             f"{REPRESENTATIONS}")


def fit_network(pairs, n, N, clips, meta, *, representation, channels, kernel, symmetrize,
                 batch_size, max_epochs, patience, tol, learning_rate, random_state, device,
                 progress, max_train, provenance):
    """The shared loop. ``pairs(rows, rng) -> (X, Y)`` builds one epoch's vectors."""
    torch = require_torch()
    from tqdm.auto import tqdm

    seed = int(random_state or 0)
    val, split_note = split_by_clip(clips, n, seed)
    train_rows, val_rows = np.flatnonzero(~val), np.flatnonzero(val)
    if max_train is not None and len(train_rows) > max_train:
        pick = np.random.default_rng([seed, 3]).choice(len(train_rows), int(max_train),
                                                       replace=False)
        train_rows = np.sort(train_rows[pick])
    if len(train_rows) < batch_size:
        raise SparseEDMError(f"{len(train_rows)} training poses (after holding out "
                             f"{len(val_rows)} for validation) are fewer than one batch "
                             f"of {batch_size}; lower batch_size or add poses")
    if len(val_rows) == 0:
        raise SparseEDMError("no validation poses: give more clips or poses")
    try:
        dev = torch.device(device)
        torch.empty(1, device=dev)
    except (RuntimeError, AssertionError) as exc:
        raise SparseEDMError(f"device {device!r} is not usable here ({exc})") from None
    torch.manual_seed(seed)
    net = build_network(N, channels, kernel, symmetrize).to(dev)
    opt = torch.optim.Adam(net.parameters(), lr=learning_rate)
    iu, ju = (torch.from_numpy(a.copy()).to(dev) for a in triu_indices(N))

    def tensors(X, Y):
        x = to_matrix(torch, torch.as_tensor(X, dtype=torch.float32, device=dev), N, iu, ju)
        y = to_matrix(torch, torch.as_tensor(Y, dtype=torch.float32, device=dev), N, iu, ju)
        return x, y

    xv, yv = tensors(*pairs(val_rows, np.random.default_rng([seed, 1])))
    rng = np.random.default_rng([seed, 2])
    best, best_state, since, history = np.inf, None, 0, []
    t0 = time.perf_counter()
    if not progress:  # else the bar says it
        _progress.say(f"training the network on {len(train_rows):,} poses ({len(val_rows):,} "
                      f"held out for early stopping), at most {max_epochs} epochs")
    bar = tqdm(range(max_epochs), disable=not progress, desc="fit-cnn", unit="epoch")
    for epoch in bar:
        net.train()
        xt, yt = tensors(*pairs(train_rows, rng))
        order = torch.from_numpy(rng.permutation(len(train_rows))).to(dev)
        total = 0.0
        for start in range(0, len(order) - batch_size + 1, batch_size):
            idx = order[start:start + batch_size]
            loss = torch.mean((net(xt[idx]) - yt[idx]) ** 2)
            opt.zero_grad()
            loss.backward()
            opt.step()
            total += loss.item() * len(idx)
        train_loss = total / (len(order) // batch_size * batch_size)
        net.eval()
        with torch.inference_mode():
            val_loss = float(torch.mean((net(xv) - yv) ** 2))
        history.append([train_loss, val_loss])
        bar.set_postfix(train=f"{train_loss:.3g}", val=f"{val_loss:.3g}")
        if val_loss < best * (1 - tol):
            best, since = val_loss, 0
            best_state = {k: v.detach().cpu().numpy().copy() for k, v in net.state_dict().items()}
        else:
            since += 1
            if since >= patience:
                break
    bar.close()
    meta = dict(meta, n_joints=int(N), representation=representation,
                channels=[int(c) for c in channels], kernel=int(kernel),
                symmetrize=bool(symmetrize),
                joint_names=list(JOINT_NAMES) if N == len(JOINT_NAMES) else [],
                training={"n_train": int(len(train_rows)), "n_val": int(len(val_rows)),
                          "validation": split_note, "random_state": seed,
                          "batch_size": int(batch_size), "learning_rate": float(learning_rate),
                          "epochs": len(history), "max_epochs": int(max_epochs),
                          "patience": int(patience), "best_val_loss": float(best),
                          "history": history, "seconds": time.perf_counter() - t0,
                          "device": str(dev), "loss": "mean squared error over the N x N EDM",
                          "provenance": provenance or {}})
    return FConvModel(best_state, meta)


class NetworkShell:
    """Stores the training arguments shared by the estimator shells."""

    def __init__(self, *, representation="average", occluded=None, channels=(32, 64),
                 kernel=3, symmetrize=False, batch_size=256, max_epochs=30, patience=4,
                 learning_rate=1e-3, random_state=0, device="cpu"):
        self.representation = representation
        self.occluded = occluded
        self.channels = channels
        self.kernel = kernel
        self.symmetrize = symmetrize
        self.batch_size = batch_size
        self.max_epochs = max_epochs
        self.patience = patience
        self.learning_rate = learning_rate
        self.random_state = random_state
        self.device = device

    def _options(self, default_occluded):
        return dict(representation=self.representation,
                    occluded=default_occluded if self.occluded is None else self.occluded,
                    channels=self.channels, kernel=self.kernel, symmetrize=self.symmetrize,
                    batch_size=self.batch_size, max_epochs=self.max_epochs,
                    patience=self.patience, learning_rate=self.learning_rate,
                    random_state=self.random_state, device=self.device)


class FConvRecoverer(NetworkShell):
    """scikit-learn-style shell: ``fit`` trains :func:`fit_fconv`, ``transform`` recovers.

    ``__init__`` only stores the arguments of :func:`fit_fconv` (``occluded=None``
    means its default, 1-3); the trained model is ``model_``.

    Parameters
    ----------
    representation : {"average", "zero"}
        How occluded joints enter the network.
    occluded : (int, int), optional
        Range of occluded joints drawn per pose and epoch.
    channels, kernel, symmetrize
        The architecture (:mod:`sparseedm.fconv.network`).
    batch_size, max_epochs, patience, learning_rate
        Adam on mini-batches; early stopping on held-out clips.
    random_state : int
        Seeds the weights, the masks and the batch order.
    device : str
        A torch device.

    Examples
    --------
    >>> import numpy as np
    >>> poses = np.random.default_rng(0).normal(size=(64, 14, 2))
    >>> est = FConvRecoverer(channels=(4, 8), batch_size=16, max_epochs=1).fit(poses)
    >>> occluded = poses[:2].copy(); occluded[:, 3] = np.nan
    >>> est.transform(occluded).shape
    (2, 14, 2)
    """

    def fit(self, X, y=None, clips=None):
        """Train on complete poses X (n, N, 2)."""
        self.model_ = fit_fconv(X, clips, **self._options((1, 3)))
        return self

    def transform(self, X, missing=None):
        """Filled poses (n, N, 2); the last RecoveryResult is ``result_``."""
        # what recover(X, missing, method="fconv", model=..., representation=...) runs,
        # called here directly: the dispatcher sits above this package
        validate_params("recover", {"representation": self.representation},
                        {"representation": [Options(REPRESENTATIONS)]})
        self.result_ = recover_fconv(X, missing, model=self.model_,
                                     representation=self.representation, chunk_size=2048)
        return self.result_.poses


__getattr__ = alias_getattr(__name__, globals())  # the older name, deprecated
