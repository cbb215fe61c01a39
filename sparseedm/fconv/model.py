"""The FConv model file: weights as named arrays plus JSON metadata, never a pickle.

A model file is a NumPy ``.npz`` read with ``allow_pickle=False`` (the same
discipline as :mod:`sparseedm.dictionary`; ``torch.load`` is never used):

``param.<name>``  float32 arrays, one per network parameter, in torch's layout
                  (:func:`sparseedm.fconv.network.param_shapes` lists them)
``meta``          0-d unicode array holding JSON: ``format`` ("sparseedm-fconv"),
                  ``format_version``, ``kind`` ("recover": occluded 2D EDM ->
                  complete 2D EDM, normalised units; "lift": 2D EDM -> 3D EDM,
                  metres), ``n_joints``, ``joint_names``, ``representation``,
                  ``channels``, ``kernel``, ``symmetrize``, ``training``
                  (data, seed, epochs, losses, time) and ``library_version``.

:func:`load_model` checks every name, shape, dtype and value against the
metadata and refuses anything else with a :class:`~sparseedm.exceptions.ModelError`
naming the file; it also refuses a model for another joint count,
representation or kind when asked (``n_joints=``, ``representation=``, ``kind=``).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._version import __version__
from .._atomic import save_npz
from .._safeio import load_npz_file, parse_meta, require_file
from ..edm import triu_indices
from ..exceptions import ModelError, SparseEDMError
from ..normalize import REPRESENTATIONS, representation_for
from .network import build_network, param_shapes, require_torch

#: a cap on any one array of a model file (the networks here hold well under 1 MB)
_MAX_BYTES = 256 << 20

__all__ = ["FConvModel", "load_model", "KINDS", "FORMAT_VERSION"]

FORMAT = "sparseedm-fconv"
FORMAT_VERSION = 1
#: what a model maps: its input -> its output
KINDS = {"recover": "occluded 2D EDM -> complete 2D EDM (normalised units)",
         "lift": "2D EDM (normalised units) -> 3D EDM (metres)"}
PARAM_PREFIX = "param."


@dataclass
class FConvModel:
    """A trained FConv network: parameters as numpy arrays plus metadata.

    Parameters
    ----------
    params : dict of str -> ndarray (float32)
    meta : dict
        ``kind``, ``n_joints``, ``joint_names``, ``representation``,
        ``channels``, ``kernel``, ``symmetrize`` and provenance.

    Examples
    --------
    >>> import numpy as np
    >>> from sparseedm.fconv.network import param_shapes
    >>> shapes = param_shapes((4, 8))
    >>> m = FConvModel({k: np.zeros(s, np.float32) for k, s in shapes.items()},
    ...                {"kind": "recover", "n_joints": 14, "representation": "zero",
    ...                 "channels": [4, 8], "kernel": 3, "symmetrize": False})
    >>> m.predict(np.ones((2, 91))).shape
    (2, 91)
    """

    params: dict
    meta: dict = field(default_factory=dict)

    def __post_init__(self):
        self.params = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in self.params.items()}
        self.meta = dict(self.meta)
        self.meta.setdefault("format", FORMAT)
        self.meta.setdefault("format_version", FORMAT_VERSION)
        self.meta.setdefault("library_version", __version__)
        _check(self.params, self.meta, "model")
        self._net = None

    @property
    def kind(self) -> str:
        return self.meta["kind"]

    @property
    def n_joints(self) -> int:
        return int(self.meta["n_joints"])

    @property
    def representation(self) -> str:
        return self.meta["representation"]

    @property
    def symmetrize(self) -> bool:
        return bool(self.meta["symmetrize"])

    def network(self):
        """The torch module (CPU, eval mode), built once from the arrays."""
        if self._net is None:
            torch = require_torch()
            net = build_network(self.n_joints, self.meta["channels"], self.meta["kernel"],
                                self.symmetrize)
            net.load_state_dict({k: torch.from_numpy(v.copy()) for k, v in self.params.items()})
            # channels-last convolutions: measured 1.4x the CPU throughput at batch 4096
            self._net = net.eval().to(memory_format=torch.channels_last)
        return self._net

    def predict(self, X, *, batch_size=4096):
        """Output EDM vectors (n, N(N-1)/2) for input EDM vectors X (n, N(N-1)/2).

        The network reads and writes full N x N matrices; its output is read
        from the upper triangle and clamped at 0.
        """
        torch = require_torch()
        X = np.asarray(X, dtype=np.float32)
        N = self.n_joints
        m = N * (N - 1) // 2
        if X.ndim != 2 or X.shape[1] != m:
            raise ModelError(f"the model reads EDM vectors of {m} entries ({N} joints), "
                             f"got shape {X.shape}")
        iu, ju = (torch.from_numpy(a.copy()) for a in triu_indices(N))
        net = self.network()
        out = np.empty(X.shape, dtype=np.float64)
        with torch.inference_mode():
            for start in range(0, len(X), batch_size):
                x = torch.from_numpy(X[start:start + batch_size])
                M = to_matrix(torch, x, N, iu, ju).contiguous(memory_format=torch.channels_last)
                y = net(M)[:, 0, iu, ju]
                out[start:start + batch_size] = y.clamp_min(0).double().numpy()
        return out

    def save(self, path):
        """Write the model atomically to `path` (.npz)."""
        path = Path(path)
        if path.suffix != ".npz":
            raise ModelError(f"{path}: a model file must end in .npz")
        arrays = {PARAM_PREFIX + k: v for k, v in self.params.items()}
        arrays["meta"] = np.array(json.dumps(self.meta, sort_keys=True), dtype=np.str_)
        return save_npz(path, arrays, compressed=True)

    def describe(self) -> str:
        m, t = self.meta, self.meta.get("training", {})
        lines = [f"FConv {m['kind']} model: {KINDS.get(m['kind'], '?')}",
                 f"{m['n_joints']} joints, representation {m['representation']}, channels "
                 f"{tuple(m['channels'])}, kernel {m['kernel']}, "
                 f"{'with' if m['symmetrize'] else 'without'} symmetrisation"]
        if t:
            lines.append(f"trained on {t.get('n_train', '?')} poses ({t.get('n_val', '?')} for "
                         f"validation), {t.get('epochs', '?')} epochs, best validation loss "
                         f"{t.get('best_val_loss', float('nan')):.4g}, seed {t.get('random_state')}")
        return "\n".join(lines)


def to_matrix(torch, x, N, iu, ju):
    """(b, m) upper-triangle vectors -> (b, 1, N, N) symmetric matrices."""
    M = x.new_zeros((x.shape[0], N, N))
    M[:, iu, ju] = x
    M[:, ju, iu] = x
    return M[:, None]


def _check(params, meta, where):
    for key in ("kind", "n_joints", "representation", "channels", "kernel", "symmetrize"):
        if key not in meta:
            raise ModelError(f"{where}: metadata lacks {key!r}")
    if meta.get("format") != FORMAT:
        raise ModelError(f"{where}: not a sparseedm FConv model (format {meta.get('format')!r})")
    if meta.get("format_version") != FORMAT_VERSION:
        raise ModelError(f"{where}: model format {meta.get('format_version')!r}, this sparseedm "
                         f"reads format {FORMAT_VERSION}")
    if meta["kind"] not in KINDS:
        raise ModelError(f"{where}: unknown model kind {meta['kind']!r}; known: {', '.join(KINDS)}")
    if meta["representation"] not in REPRESENTATIONS:
        raise ModelError(f"{where}: unknown representation {meta['representation']!r}")
    try:
        expected = param_shapes(meta["channels"], meta["kernel"])
        n_joints = int(meta["n_joints"])
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{where}: invalid architecture metadata ({exc})") from None
    if n_joints < 4:
        raise ModelError(f"{where}: n_joints must be >= 4, got {n_joints}")
    if set(params) != set(expected):
        raise ModelError(f"{where}: parameters {sorted(params)} do not match the architecture "
                         f"{sorted(expected)}")
    for name, shape in expected.items():
        if params[name].shape != shape:
            raise ModelError(f"{where}: parameter {name} has shape {params[name].shape}, the "
                             f"architecture needs {shape}")
        if not np.isfinite(params[name]).all():
            raise ModelError(f"{where}: parameter {name} holds NaN or inf")


def load_model(path, *, n_joints=None, representation=None, kind=None) -> FConvModel:
    """Load and validate an FConv model file.

    Parameters
    ----------
    path : str or path-like
    n_joints, representation, kind : optional
        Refuse a model made for another joint count, input representation
        or task.

    Returns
    -------
    FConvModel
        The validated model.

    Raises
    ------
    ModelError
        Missing, truncated, pickled or malformed file; a model that does not
        fit what was asked.
    """
    if isinstance(path, FConvModel):
        model, where = path, "model"
    else:
        path = Path(path)
        where = str(path)
        require_file(path, "model", ModelError)  # a folder or device is named as such
        # the bounded reader: sizes checked before anything is decompressed
        arrays, _ = load_npz_file(
            path, lambda names: ["meta"] + [k for k in names if k.startswith(PARAM_PREFIX)],
            error=ModelError, kind="model", max_bytes=_MAX_BYTES)
        if "meta" not in arrays:
            raise ModelError(f"{path}: not a sparseedm FConv model (no 'meta' array)")
        meta = parse_meta(arrays.pop("meta"), path, error=ModelError)
        params = {k[len(PARAM_PREFIX):]: v for k, v in arrays.items()}
        for name, value in params.items():
            if value.dtype != np.float32:
                raise ModelError(f"{path}: parameter {name} must be float32, got {value.dtype}")
        _check(params, meta, where)
        model = FConvModel(params, meta)
    if n_joints is not None and model.n_joints != int(n_joints):
        raise ModelError(f"{where}: the model is for {model.n_joints} joints, the data has "
                         f"{n_joints}")
    if representation is not None:  # None: the model's own
        try:
            representation_for(representation, model.representation, where)
        except SparseEDMError as exc:
            raise ModelError(str(exc)) from None
    if kind is not None and model.kind != kind:
        raise ModelError(f"{where}: a {model.kind!r} model ({KINDS[model.kind]}), but a "
                         f"{kind!r} model is needed ({KINDS[kind]})")
    return model
