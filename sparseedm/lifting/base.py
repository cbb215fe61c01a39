"""The lifter interface, the 3D normalisation, and the lifter file format.

A *lifter* maps normalised 2D EDM vectors (91 entries for 14 joints, see
:mod:`sparseedm.normalize`) to 3D EDM vectors, possibly from the observed
entries only. Each method is a subclass of :class:`Lifter` in its own module,
registered by name in :data:`LIFTERS` (module and class, imported lazily):

``dictionary``  :class:`sparseedm.lifting.dictionary.DictionaryLifter` (default)
``mlp``         :class:`sparseedm.lifting.mlp.MLPLifter` (DMR's FConn)
``fconv``       :class:`sparseedm.lifting.fconv.FConvNetLifter` (DMR's fully
                convolutional network; needs the torch extra to fit and predict)

A file whose method is not registered is refused with a message naming the
methods this installation knows.

3D normalisation ("tied", the default)
--------------------------------------
A 2D pose is normalised by its bounding box: ``p_norm = (p - c) / s`` (pixels).
Under a weak-perspective camera a camera-frame 3D point X projects to
``f X_xy / Z`` with Z the depth of the pose centre, so the 3D pose in the
*same units* as the normalised 2D pose is ``X f / (Z s)``. Training targets
are the 3D EDM vectors in these units (exact for training poses, whose camera
is known): 2D and 3D halves then scale together, and a lifted pose overlays
its 2D input with scale ~1. ``"unit"`` (the alternative measured on the
validation split) scales each 3D EDM vector to unit RMS instead.

Metric scale: one image does not fix absolute size (a bigger person further
away looks the same), so metric 3D poses are the lifted shape scaled to the
training poses' median size: ``size_prior`` = median RMS entry of the metric
3D EDM vectors (metres). Metrics say how they treat scale
(:mod:`sparseedm.lifting.metrics`).

File format
-----------
A lifter file is an ``.npz`` read with ``allow_pickle=False`` (a pickle is
refused, never executed) holding ``joint_names`` (N,), ``chirality`` (the
reflection prior's coefficients, C(N,4)), ``meta`` (0-d JSON string:
``format_version``, ``kind`` = ``"sparseedm-lifter"``, ``method``, the
method's parameters, ``normalization``, ``size_prior``, ``provenance``,
``library_version``) and the method's arrays (``components`` for
``dictionary``; ``coef_0``, ``intercept_0``, ... for ``mlp``).
"""

from __future__ import annotations

import importlib
import json
from pathlib import Path

import numpy as np

from .. import _progress
from .._version import __version__
from .._atomic import save_npz
from .._safeio import load_npz, load_npz_file, parse_meta, require_file
from .._shipped import resolve_shipped, shipped_names
from ..edm import pose_to_vector
from ..exceptions import DictionaryError, PoseError, SparseEDMError
from ..normalize import normalize
from ..skeleton import JOINT_NAMES
from .mds import ChiralityPrior

__all__ = ["Lifter", "LifterError", "LIFTERS", "NORMALIZATIONS", "DEFAULT_LIFTER",
           "load_lifter", "available_lifters", "training_pairs", "is_lifter_file"]

FORMAT_VERSION = 1
KIND = "sparseedm-lifter"
#: 3D EDM normalisations (see the module docstring)
NORMALIZATIONS = ("tied", "unit")
#: name -> (module, class)
LIFTERS = {
    "dictionary": ("sparseedm.lifting.dictionary", "DictionaryLifter"),
    "mlp": ("sparseedm.lifting.mlp", "MLPLifter"),
    "fconv": ("sparseedm.lifting.fconv", "FConvNetLifter"),
}
#: the shipped lifter the name "default" resolves to (package sparseedm.lifters)
DEFAULT_LIFTER = "cmu-lift"
#: a cap on any one array of a lifter file (the shipped one holds 2.7 MB)
_MAX_BYTES = 1 << 30


class LifterError(DictionaryError):
    """A lifter file that is corrupt, unsafe, unknown or does not fit the data."""


def training_pairs(poses2d, poses3d, camera_R, camera_t, camera_f, normalization="tied"):
    """2D and 3D EDM vectors of complete training poses.

    Parameters
    ----------
    poses2d : (n, N, 2) pixels
    poses3d : (n, N, 3) world coordinates (metres)
    camera_R, camera_t, camera_f : the pinhole camera of each pose
        (``x_cam = R X + t``, as :mod:`sparseedm.cameras`)
    normalization : {"tied", "unit"}

    Returns
    -------
    X2 : (n, M) normalised 2D EDM vectors
    X3 : (n, M) 3D EDM vectors in the chosen normalisation
    metric : (n, M) 3D EDM vectors in metres
    cam3d : (n, N, 3) camera-frame 3D poses (metres)
    """
    if normalization not in NORMALIZATIONS:
        raise SparseEDMError(f"unknown normalization {normalization!r}; use one of {NORMALIZATIONS}")
    poses2d = np.asarray(poses2d, float)
    poses3d = np.asarray(poses3d, float)
    if poses3d.shape[:2] != poses2d.shape[:2] or poses3d.shape[-1] != 3:
        raise PoseError(f"poses3d must have shape {poses2d.shape[:2] + (3,)}, got {poses3d.shape}")
    normed, _, s2 = normalize(poses2d)
    X2 = pose_to_vector(normed)
    cam3d = np.einsum("nij,nkj->nki", np.asarray(camera_R, float), poses3d) + np.asarray(
        camera_t, float)[:, None, :]
    metric = pose_to_vector(cam3d)
    X3 = to_normalized(metric, normalization, depth=cam3d[..., 2].mean(axis=1),
                       focal=np.asarray(camera_f, float), scale2d=s2)
    return X2, X3, metric, cam3d


def to_normalized(metric, normalization, depth=None, focal=None, scale2d=None):
    """Metric 3D EDM vectors -> the lifter's normalisation (needs the camera for "tied")."""
    metric = np.asarray(metric, float)
    if normalization == "tied":
        return metric * (np.asarray(focal) / (np.asarray(depth) * np.asarray(scale2d)))[:, None]
    rms = np.sqrt((metric ** 2).mean(axis=1, keepdims=True))
    return metric / rms


def rms(vectors):
    """Root-mean-square entry of each EDM vector (a pose's size)."""
    return np.sqrt((np.asarray(vectors, float) ** 2).mean(axis=-1))


def check_pairs(X2, X3):
    X2 = np.asarray(X2, float)
    X3 = np.asarray(X3, float)
    if X2.ndim != 2 or X2.shape != X3.shape:
        raise SparseEDMError(f"X2 and X3 must both be (n, M), got {X2.shape} and {X3.shape}")
    if not (np.isfinite(X2).all() and np.isfinite(X3).all()):
        raise SparseEDMError("training vectors contain NaN or inf")
    return X2, X3


class Lifter:
    """Base class: 2D EDM vectors -> 3D EDM vectors, plus what every lifter carries.

    Subclasses set ``method``, implement :meth:`predict`, :meth:`_fit`,
    :meth:`_arrays` and :meth:`_from_arrays`, and list their parameters in
    ``_params`` (stored in the file's meta).

    Parameters
    ----------
    normalization : {"tied", "unit"}
        3D EDMs in the 2D normaliser's units (``"tied"``) or scaled to unit RMS.
    random_state : int
        Seed of the learning.

    Notes
    -----
    Learned state (common): ``chirality_`` (:class:`ChiralityPrior`),
    ``size_prior_`` (metres), ``joint_names_``, ``provenance_``.
    """

    method = "base"
    _params = ("normalization", "random_state")
    #: whether predict uses only the observed entries (True) or a whole
    #: 'average'/'zero' vector (False)
    codes_observed_only = False
    #: the representation of occluded input the lifter was trained on (an FConv
    #: lifter's own); None: it was trained on complete poses, any one may be fed
    representation = None

    def __init__(self, *, normalization="tied", random_state=0):
        self.normalization = normalization
        self.random_state = random_state

    # -- fitting -----------------------------------------------------------
    def fit(self, X2, X3):
        """Learn the 2D -> 3D map from paired EDM vectors (n, M)."""
        self._fit(*check_pairs(X2, X3))
        return self

    def fit_poses(self, poses2d, poses3d, camera_R, camera_t, camera_f, *, provenance=None,
                  joint_names=JOINT_NAMES, clips=None):
        """Fit from a training set's arrays (as ``sparseedm dataset build`` writes them).

        `clips` (the clip of each pose) is used by lifters that hold out
        validation clips (``fconv``); the others ignore it.
        """
        _progress.say(f"fitting a {self.method} lifter on {len(poses2d):,} training poses")
        X2, X3, metric, cam3d = training_pairs(poses2d, poses3d, camera_R, camera_t, camera_f,
                                               self.normalization)
        self._fit_from_poses(X2, X3, poses2d, clips)
        _progress.say("fitting the depth-reflection (chirality) prior")
        self.chirality_ = ChiralityPrior().fit(cam3d, random_state=self.random_state)
        self.size_prior_ = float(np.median(rms(metric)))
        self.joint_names_ = tuple(joint_names)
        self.provenance_ = dict(provenance or {}, n_poses=int(len(X2)))
        return self

    def _fit(self, X2, X3):  # pragma: no cover - abstract
        raise NotImplementedError

    def _fit_from_poses(self, X2, X3, poses2d, clips):
        """Fit from the pairs; lifters that also need the 2D poses or clips override this."""
        self.fit(X2, X3)

    # -- prediction --------------------------------------------------------
    def predict(self, X2, missing=None, *, n_jobs=1):
        """3D EDM vectors (n, M) in the lifter's normalisation, and per-row info.

        Returns ``(X3, info)``; ``info`` is a dict of per-row arrays, at least
        ``status`` ("optimal", "inaccurate" or "failed").
        """
        raise NotImplementedError  # pragma: no cover

    @property
    def n_joints(self):
        return len(self.joint_names_)

    # -- file format -------------------------------------------------------
    def meta(self):
        return {
            "format_version": FORMAT_VERSION,
            "kind": KIND,
            "method": self.method,
            "params": {p: getattr(self, p) for p in self._params},
            "size_prior": self.size_prior_,
            "provenance": self.provenance_,
            "library_version": __version__,
        }

    def save(self, path):
        """Write the lifter atomically to `path` (.npz, no pickles)."""
        path = Path(path)
        if path.suffix != ".npz":
            raise LifterError(f"{path}: a lifter file must end in .npz")
        arrays = self._arrays()
        arrays.update(
            joint_names=np.array(self.joint_names_, dtype=np.str_),
            chirality=np.asarray(self.chirality_.coef_, float),
            meta=np.array(json.dumps(self.meta(), sort_keys=True), dtype=np.str_),
        )
        return save_npz(path, arrays, compressed=True)

    def describe(self):
        """A few lines a person reads (``sparseedm info``)."""
        p = self.provenance_ or {}
        params = ", ".join(f"{k}={getattr(self, k)}" for k in self._params)
        lines = [
            f"lifter '{self.method}': 2D EDM ({self.n_joints} joints: "
            f"{', '.join(self.joint_names_)}) -> 3D EDM -> MDS",
            self._describe_model(),
            f"parameters: {params}",
            f"3D normalisation: {self.normalization}; metric size prior "
            f"{self.size_prior_:.4f} m (median RMS 3D distance of the training poses)",
        ]
        if p:
            files = p.get("files", [])
            lines.append(f"learned from {p.get('n_poses', '?')} poses in "
                         f"{', '.join(files[:3]) or '?'}"
                         + (f" and {len(files) - 3} more" if len(files) > 3 else ""))
        return "\n".join(lines)

    def _describe_model(self):  # pragma: no cover - overridden
        return ""

    def _arrays(self):  # pragma: no cover - abstract
        raise NotImplementedError

    @classmethod
    def _from_arrays(cls, arrays, params, where):  # pragma: no cover - abstract
        raise NotImplementedError


def lifter_class(method, where):
    if method not in LIFTERS:
        raise LifterError(
            f"{where}: lifter method {method!r} is not available in this sparseedm "
            f"(known: {', '.join(LIFTERS)})")
    module, name = LIFTERS[method]
    return getattr(importlib.import_module(module), name)


def available_lifters():
    """Names of the lifters shipped with the package ("default" included).

    Returns
    -------
    list of str
        Names :func:`load_lifter` accepts.
    """
    return shipped_names("sparseedm.lifters", DEFAULT_LIFTER)


def _resolve(name_or_path):
    return resolve_shipped(name_or_path, "sparseedm.lifters", DEFAULT_LIFTER, LifterError,
                           "lifter")


def is_lifter_file(name_or_path):
    """True when `name_or_path` names a shipped lifter or an .npz holding a lifter's meta.

    ``None`` and ``"default"`` are not lifters here: they name the default dictionary.

    Parameters
    ----------
    name_or_path : str, path-like or None
        A shipped name or a file.

    Returns
    -------
    bool
        Whether it is a lifter.
    """
    if name_or_path is None or name_or_path == "default":
        return False
    try:
        path = _resolve(name_or_path)
        meta = load_npz(path, ("meta",), max_bytes=1 << 20)[0].get("meta")
        return meta is not None and json.loads(str(meta)).get("kind") == KIND
    except Exception:  # any unreadable file is not a lifter file
        return False


def load_lifter(name_or_path=None, *, n_joints=None):
    """Load and validate a lifter by shipped name or path.

    Parameters
    ----------
    name_or_path : str or path-like, optional
        A shipped lifter's name (default: the default lifter) or a lifter ``.npz``.
    n_joints : int, optional
        Refuse a lifter for another joint count.

    Returns
    -------
    Lifter
        The lifter, of its file's method.

    Raises
    ------
    LifterError
        Missing, truncated, pickled or malformed file; an unknown method; a
        lifter for another joint count than `n_joints`.

    Examples
    --------
    >>> import sparseedm
    >>> lifter = sparseedm.load_lifter()             # the shipped default, cmu-lift
    >>> lifter.method
    'dictionary'
    """
    if isinstance(name_or_path, Lifter):
        lifter = name_or_path
        where = f"lifter {lifter.method!r}"
    else:
        path = _resolve(name_or_path)
        where = str(path)
        require_file(path, "lifter", LifterError)
        # the bounded reader: declared sizes checked before anything is decompressed
        arrays, _ = load_npz_file(path, list, error=LifterError, kind="lifter",
                                  max_bytes=_MAX_BYTES)
        missing = {"meta", "joint_names", "chirality"} - set(arrays)
        if missing:
            raise LifterError(f"{path}: not a sparseedm lifter (missing "
                              f"{', '.join(sorted(missing))})")
        meta = parse_meta(arrays.pop("meta"), path, error=LifterError)
        if meta.get("kind") != KIND or meta.get("format_version") != FORMAT_VERSION:
            raise LifterError(f"{path}: not a sparseedm lifter of format {FORMAT_VERSION} "
                              f"(kind {meta.get('kind')!r}, format {meta.get('format_version')!r})")
        names = arrays.pop("joint_names")
        if names.dtype.kind != "U" or names.ndim != 1:
            raise LifterError(f"{path}: joint_names must be a 1-D string array")
        chir = arrays.pop("chirality")
        N = len(names)
        n_quads = N * (N - 1) * (N - 2) * (N - 3) // 24
        if chir.dtype.kind != "f" or chir.shape != (n_quads,) or not np.isfinite(chir).all():
            raise LifterError(f"{path}: chirality must be {n_quads} finite floats for {N} joints")
        cls = lifter_class(meta.get("method"), path)
        try:
            lifter = cls._from_arrays(arrays, dict(meta.get("params", {})), where)
            lifter.size_prior_ = float(meta["size_prior"])
        except LifterError:
            raise
        except (KeyError, TypeError, ValueError) as exc:
            raise LifterError(f"{path}: lifter data incomplete or invalid ({exc})") from None
        if not (np.isfinite(lifter.size_prior_) and lifter.size_prior_ > 0):
            raise LifterError(f"{path}: size_prior must be > 0")
        lifter.chirality_ = ChiralityPrior()
        lifter.chirality_.coef_ = chir.astype(float)
        lifter.joint_names_ = tuple(str(n) for n in names)
        lifter.provenance_ = meta.get("provenance", {})
        lifter._check_dims(N, where)
    if n_joints is not None and lifter.n_joints != n_joints:
        raise LifterError(f"{where}: lifter is for {lifter.n_joints} joints, the poses have "
                          f"{n_joints}")
    return lifter
