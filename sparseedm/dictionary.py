"""The dictionary file format: a safe .npz with atoms and everything needed to use them.

A dictionary file is a NumPy ``.npz`` archive, read with ``allow_pickle=False``
(a pickle is refused, never executed), holding:

``components``
    float64 (k, N(N-1)/2): unit-norm atoms as rows (the paper's D is
    its transpose)
``joint_names``
    unicode (N,): the joint layout the atoms describe
``meta``
    a 0-d unicode array holding JSON: ``format_version``,
    ``representation`` and ``normalization`` of the training vectors,
    ``alpha_train``, ``alpha_recover`` (recommended recovery alpha),
    ``alpha_scaling``, ``recovery_scale`` (how recovery normalises a
    pose: ``"radius"``, rotation-invariant, or ``"box"``, the bounding
    box; a file without the field was made for ``"box"`` and keeps it),
    ``positive_code``, ``provenance`` (training files, pose count, sha256
    of the training poses, seed, passes, batch size) and
    ``library_version``.

:func:`load_dictionary` checks shape, dtype, finiteness and unit norm and
refuses anything else with a :class:`~sparseedm.exceptions.DictionaryError`.
Shipped dictionaries load by name (``"default"``) from the installed package.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field, replace
from numbers import Integral, Real
from pathlib import Path

import numpy as np

from ._version import __version__
from ._atomic import save_npz
from ._safeio import available_memory, load_npz_file, parse_meta, require_file
from ._shipped import resolve_shipped, shipped_names
from ._validation import ALPHA_MAX, ALPHA_MIN, Interval, validate_params
from .edm import num_joints_from_dim, triu_indices
from .normalize import SCALE_RULES
from .exceptions import DictionaryError, PoseError
from .skeleton import JOINT_NAMES, SKELETON_14

__all__ = ["Dictionary", "load_dictionary", "available_dictionaries", "check_layout",
           "check_gram_memory",
           "DEFAULT_DICTIONARY"]

FORMAT_VERSION = 1
#: the file the name "default" resolves to, in the sparseedm.dictionaries package
DEFAULT_DICTIONARY = "cmu-all-k2000"
_UNIT_NORM_TOL = 1e-6


@dataclass
class Dictionary:
    """Learned atoms plus what is needed to use them correctly.

    Parameters
    ----------
    components : ndarray, shape (n_components, n_features)
        Unit-norm atoms as rows; n_features = N(N-1)/2 distances for N joints.
    joint_names : tuple of str
        The N joints, in the order of the poses the atoms code (default the
        14-joint layout, :data:`sparseedm.skeleton.JOINT_NAMES`).
    alpha_recover : float
        Recommended lasso penalty for recovery (before `alpha_scaling`).
    alpha_train : float
        The lasso penalty the atoms were learned with.
    alpha_scaling : {"entries", "none"}
        How recovery scales alpha with the number of observed entries.
    positive_code : bool
        Codes are non-negative (learned so, and recovered so by default).
    representation, normalization : str
        How the training vectors were made.
    recovery_scale : {"radius", "box"}
        How recovery normalises a pose from its observed joints
        (:func:`sparseedm.normalize.normalize`'s rule): ``"radius"`` (the
        same whatever the body's rotation in the image plane) or ``"box"``
        (the bounding box, which a rotation changes; files that predate the
        field, whose alpha was chosen with it, keep it).
    provenance : dict
        What the atoms were learned from and with which settings (files,
        pose count, the training poses' sha256, seeds): JSON-able.
    library_version : str
        The sparseedm version that wrote the dictionary.

    Examples
    --------
    >>> import numpy as np
    >>> comp = np.eye(3)
    >>> d = Dictionary(comp, ("a", "b", "c"), alpha_recover=0.1)
    >>> d.n_components, d.n_joints, d.n_features
    (3, 3, 3)
    """

    components: np.ndarray
    joint_names: tuple = JOINT_NAMES
    alpha_recover: float = 0.01
    alpha_train: float = 0.05
    alpha_scaling: str = "entries"
    positive_code: bool = False
    representation: str = "complete"
    normalization: str = "bbox: center (min+max)/2, scale max(max-min)/2, one scale for x and y"
    recovery_scale: str = "radius"
    provenance: dict = field(default_factory=dict)
    library_version: str = __version__

    def __post_init__(self):
        self.components = np.asarray(self.components, dtype=np.float64)
        self.joint_names = tuple(str(n) for n in self.joint_names)
        _check_components(self.components, self.joint_names, "components")
        if isinstance(self.positive_code, np.bool_):
            self.positive_code = bool(self.positive_code)
        _check_meta({"format_version": FORMAT_VERSION, "alpha_recover": self.alpha_recover,
                     "alpha_train": self.alpha_train, "alpha_scaling": self.alpha_scaling,
                     "positive_code": self.positive_code,
                     "representation": self.representation,
                     "normalization": self.normalization,
                     "recovery_scale": self.recovery_scale, "provenance": self.provenance,
                     "library_version": self.library_version}, "Dictionary")
        if self.alpha_scaling not in ("entries", "none"):
            raise DictionaryError(
                f"alpha_scaling must be 'entries' or 'none', got {self.alpha_scaling!r}"
            )

    @property
    def n_components(self) -> int:
        """The number of atoms, k."""
        return self.components.shape[0]

    @property
    def n_features(self) -> int:
        """The length of an atom: N(N-1)/2 distances."""
        return self.components.shape[1]

    @property
    def n_joints(self) -> int:
        """The number of joints N."""
        return len(self.joint_names)

    def meta(self) -> dict:
        """The JSON-able metadata stored beside the arrays.

        Returns
        -------
        dict
            The format version, the alphas and their scaling, the code sign,
            the normalisations, `provenance` and the library version.
        """
        return {
            "format_version": FORMAT_VERSION,
            "alpha_recover": float(self.alpha_recover),
            "alpha_train": float(self.alpha_train),
            "alpha_scaling": self.alpha_scaling,
            "positive_code": bool(self.positive_code),
            "representation": self.representation,
            "normalization": self.normalization,
            "recovery_scale": self.recovery_scale,
            "provenance": self.provenance,
            "library_version": self.library_version,
        }

    def mirrored(self) -> "Dictionary":
        """The dictionary that codes a pose as this one codes its mirror image.

        Each atom's distances are permuted as swapping every left joint with
        its right one permutes a pose's: coding a pose over the result and
        coding its mirror image (left and right swapped, x negated) over this
        dictionary give the same joints, mirrored back. Needs the 14-joint
        layout (:data:`sparseedm.skeleton.JOINT_NAMES`), whose left and right
        joints are known.

        Returns
        -------
        Dictionary
            The same settings, the permuted atoms.

        Raises
        ------
        DictionaryError
            The dictionary's joints are not the 14-joint layout.

        Examples
        --------
        >>> d = load_dictionary()
        >>> bool((d.mirrored().mirrored().components == d.components).all())
        True
        """
        if self.joint_names != JOINT_NAMES:
            raise DictionaryError("mirroring needs the 14-joint layout's left and right "
                                  f"joints; this dictionary's joints are {self.joint_names}")
        return replace(self, components=self.components[:, _mirror_entries(self.n_joints)])

    def save(self, path):
        """Write the dictionary atomically to `path` (.npz).

        Parameters
        ----------
        path : str or path-like
            The file to write; it must end in ``.npz``.

        Returns
        -------
        Path
            `path`, written.

        Raises
        ------
        DictionaryError
            `path` does not end in ``.npz``.

        Examples
        --------
        >>> import tempfile, pathlib
        >>> d = load_dictionary()
        >>> with tempfile.TemporaryDirectory() as tmp:
        ...     path = d.save(pathlib.Path(tmp) / "mine.npz")
        ...     load_dictionary(path).n_components
        2000
        """
        path = Path(path)
        if path.suffix != ".npz":
            raise DictionaryError(f"{path}: a dictionary file must end in .npz")
        return save_npz(path, dict(
            components=self.components,
            joint_names=np.array(self.joint_names, dtype=np.str_),
            meta=np.array(json.dumps(self.meta(), sort_keys=True), dtype=np.str_),
        ), compressed=True)

    def describe(self) -> str:
        """A few lines a person reads (what ``sparseedm info`` prints).

        Returns
        -------
        str
            Atoms and joints, alphas, normalisations, what the atoms were
            learned from, the settings and the version that wrote them, one
            per line.
        """
        p = self.provenance or {}
        lines = [
            f"{self.n_components} atoms over {self.n_features} distances "
            f"({self.n_joints} joints: {', '.join(self.joint_names)})",
            f"recovery alpha {self.alpha_recover:g} (scaled by: {self.alpha_scaling}); "
            f"training alpha {self.alpha_train:g}; "
            f"{'non-negative' if self.positive_code else 'signed'} codes",
            f"training vectors: {self.representation} poses, normalised by {self.normalization}",
            f"recovery normalises a pose by its observed joints' {_SCALE_WORDS[self.recovery_scale]}",
        ]
        if p:
            files = p.get("files", [])
            shown = ", ".join(files[:3]) + (f" and {len(files) - 3} more" if len(files) > 3 else "")
            lines.append(
                f"learned from {p.get('n_poses', '?')} poses in {shown or '?'}"
                + (f" (sha256 {p['sha256'][:12]}...)" if p.get("sha256") else "")
            )
            extras = {k: v for k, v in p.items()
                      if k not in ("files", "n_poses", "sha256", "sha256_of")}
            if extras:
                lines.append("settings: " + ", ".join(f"{k}={v}" for k, v in sorted(extras.items())))
        lines.append(f"written by sparseedm {self.library_version}")
        return "\n".join(lines)


def _mirror_entries(n_joints):
    """Entry order of a mirrored pose's EDM vector: entry (i, j) of the mirror
    image is entry (flip[i], flip[j]) of the pose."""
    rows, cols = triu_indices(n_joints)
    flip = SKELETON_14.flip_permutation()
    a, b = flip[rows], flip[cols]
    where = {pair: k for k, pair in enumerate(zip(rows.tolist(), cols.tolist()))}
    return np.array([where[(min(i, j), max(i, j))] for i, j in zip(a.tolist(), b.tolist())])


def _check_components(components, joint_names, where):
    if components.ndim != 2:
        raise DictionaryError(f"{where}: atoms must be 2-D (k, n_features), got {components.shape}")
    k, m = components.shape
    if k < 1:
        raise DictionaryError(f"{where}: the dictionary has no atoms")
    try:
        n = num_joints_from_dim(m)
    except PoseError as exc:
        raise DictionaryError(f"{where}: {exc}") from None
    if n != len(joint_names):
        raise DictionaryError(
            f"{where}: atoms have {m} entries (N={n} joints) but {len(joint_names)} "
            "joint names are given"
        )
    if not np.isfinite(components).all():
        raise DictionaryError(f"{where}: atoms contain NaN or inf")
    norms = np.linalg.norm(components, axis=1)
    if np.abs(norms - 1).max() > _UNIT_NORM_TOL:
        worst = int(np.abs(norms - 1).argmax())
        raise DictionaryError(
            f"{where}: atom {worst} has norm {norms[worst]:.6g}; atoms must have unit norm"
        )


def check_layout(dictionary, joint_names=JOINT_NAMES, where="poses"):
    """Refuse a dictionary whose joints are not `joint_names`, in that order.

    Poses are arrays whose joint axis follows a layout (SKELETON_14 for every
    file sparseedm reads): atoms of another order or naming would be used
    silently wrong.

    Parameters
    ----------
    dictionary : Dictionary
        The dictionary to check.
    joint_names : sequence of str
        The poses' joint layout.
    where : str
        What to name in the error message.

    Examples
    --------
    >>> import numpy as np
    >>> d = Dictionary(np.eye(91)[:2], JOINT_NAMES[::-1])
    >>> check_layout(d)
    Traceback (most recent call last):
    ...
    sparseedm.exceptions.DictionaryError: the dictionary's joints are not the layout the poses use (SKELETON_14): position 0 is 'left_ankle', the poses have 'head_top'
    """
    names = tuple(dictionary.joint_names)
    want = tuple(joint_names)
    if names == want:
        return
    if len(names) != len(want):
        raise DictionaryError(
            f"the dictionary is for {len(names)} joints, the {where} have {len(want)}")
    k = next(i for i, (a, b) in enumerate(zip(names, want)) if a != b)
    layout = " (SKELETON_14)" if want == JOINT_NAMES else ""
    raise DictionaryError(
        f"the dictionary's joints are not the layout the {where} use{layout}: position "
        f"{k} is {names[k]!r}, the {where} have {want[k]!r}")


_META_TYPES = {  # field -> (kind, required)
    "format_version": (Integral, True),
    "alpha_recover": (Real, True),
    "alpha_train": (Real, True),
    "alpha_scaling": (str, False),
    "positive_code": (bool, False),
    "representation": (str, False),
    "normalization": (str, False),
    "recovery_scale": (str, False),
    "provenance": (dict, False),
    "library_version": (str, False),
}
#: metadata fields with a closed set of values (anything else would be applied as
#: if it were the one rule recovery knows); normalization: "bbox" or "bbox: ..."
#: (the rule spelled out), or "" for files that predate the field
#: how `describe` names each recovery_scale rule
_SCALE_WORDS = {"radius": "centroid and RMS radius (rotation-invariant)",
                "box": "bounding box"}
_META_CHOICES = {"alpha_scaling": ("entries", "none"), "recovery_scale": SCALE_RULES,
                 "representation": ("complete", "average", "zero")}
_PROVENANCE_TYPES = {"files": list, "n_poses": Integral, "sha256": str, "sha256_of": str}


def _check_meta(meta, where):
    """Every metadata field of the right type (a clear error, not an AttributeError)."""
    if not isinstance(meta, dict):
        raise DictionaryError(
            f"{where}: metadata must be a JSON object, got {type(meta).__name__}")
    for key, (kind, required) in _META_TYPES.items():
        if key not in meta:
            if required:
                raise DictionaryError(f"{where}: metadata has no {key!r}")
            continue
        value = meta[key]
        ok = isinstance(value, kind) and (kind is bool or not isinstance(value, bool))
        if not ok:
            raise DictionaryError(
                f"{where}: metadata {key!r} must be {kind.__name__.lower()}, got "
                f"{type(value).__name__} {str(value)[:40]!r}")
    for key in ("alpha_recover", "alpha_train"):
        if not (np.isfinite(meta[key]) and ALPHA_MIN <= meta[key] <= ALPHA_MAX):
            raise DictionaryError(f"{where}: metadata {key!r} must be in [{ALPHA_MIN:g}, "
                                  f"{ALPHA_MAX:g}] (where the lasso is meaningful), got "
                                  f"{meta[key]!r}")
    for key, allowed in _META_CHOICES.items():
        if key in meta and meta[key] not in allowed:
            raise DictionaryError(f"{where}: metadata {key!r} must be one of "
                                  f"{', '.join(map(repr, allowed))}, got {str(meta[key])[:40]!r}")
    norm = meta.get("normalization", "")
    if not (norm in ("", "bbox") or norm.startswith("bbox:")):
        raise DictionaryError(
            f"{where}: metadata 'normalization' must be 'bbox' (the [-1, 1] bounding-box "
            f"normalisation recovery applies), got {norm[:40]!r}")
    for key, kind in _PROVENANCE_TYPES.items():
        value = meta.get("provenance", {}).get(key)
        if value is not None and (not isinstance(value, kind) or isinstance(value, bool)):
            raise DictionaryError(
                f"{where}: metadata provenance {key!r} must be {kind.__name__.lower()}, "
                f"got {type(value).__name__}")
    files = meta.get("provenance", {}).get("files") or []
    if not all(isinstance(f, str) for f in files):
        raise DictionaryError(f"{where}: metadata provenance 'files' must be strings")


def check_gram_memory(dictionary):
    """Refuse a dictionary whose (k, k) Gram matrix, which recovery and adaptation
    build, would take more than half the memory available (a DictionaryError
    naming the sizes), before anything is allocated.

    Parameters
    ----------
    dictionary : Dictionary
        The dictionary to check.

    Examples
    --------
    >>> check_gram_memory(Dictionary(np.eye(91)[:3]))
    """
    k = dictionary.n_components
    need = 8 * k * k
    free = available_memory()
    if free is not None and need > free // 2:
        raise DictionaryError(
            f"the dictionary's {k} atoms need a {need / 2**30:.1f} GiB Gram matrix (k x k) "
            f"and {free / 2**30:.1f} GiB of memory is available: use a dictionary with "
            f"fewer atoms (the shipped ones have 2000)")


def available_dictionaries() -> list[str]:
    """Names of the dictionaries shipped with the package ("default" included).

    Returns
    -------
    list of str
        Names :func:`load_dictionary` accepts.
    """
    # a pose bank (sparseedm.cold_bank, "*-bank") ships beside them: no dictionary
    return [n for n in shipped_names("sparseedm.dictionaries", DEFAULT_DICTIONARY)
            if not n.endswith("-bank")]


def dictionary_path(name_or_path):
    return resolve_shipped(name_or_path, "sparseedm.dictionaries", DEFAULT_DICTIONARY,
                           DictionaryError, "dictionary")


#: the earlier name of this function (kept for code that uses it)
_resolve = dictionary_path


def load_dictionary(name_or_path=None, *, n_joints=None) -> Dictionary:
    """Load and validate a dictionary by shipped name or path.

    Parameters
    ----------
    name_or_path : str or path-like, optional
        ``None`` or ``"default"`` for the shipped default, another shipped
        name, or a path to an .npz file.
    n_joints : int, optional
        Refuse a dictionary for another joint count.

    Returns
    -------
    Dictionary
        The validated dictionary.

    Raises
    ------
    DictionaryError
        Missing, truncated, pickled or malformed file; non-finite or
        non-unit atoms; wrong joint count.

    Examples
    --------
    >>> import sparseedm
    >>> d = sparseedm.load_dictionary()            # the shipped default
    >>> d.n_components, d.n_joints
    (2000, 14)
    >>> sparseedm.load_dictionary("cmu-coco-k2932").n_components
    2932
    """
    validate_params("load_dictionary", dict(name_or_path=name_or_path, n_joints=n_joints),
                    {"name_or_path": ["path", None],
                     "n_joints": [Interval(Integral, 1, None), None]})
    path = dictionary_path(name_or_path)
    require_file(path, "dictionary", DictionaryError)
    arrays, names = load_npz_file(path, ("components", "joint_names", "meta"),
                                  error=DictionaryError, kind="dictionary",
                                  max_bytes=_MAX_BYTES)
    missing = {"components", "joint_names", "meta"} - set(arrays)
    if missing:
        raise DictionaryError(
            f"{path}: not a sparseedm dictionary (missing {', '.join(sorted(missing))})")
    components, joint_names, meta_text = (
        arrays["components"], arrays["joint_names"], arrays["meta"])
    if components.dtype.kind != "f":
        raise DictionaryError(f"{path}: atoms must be floating point, got {components.dtype}")
    if joint_names.dtype.kind != "U" or joint_names.ndim != 1:
        raise DictionaryError(f"{path}: joint_names must be a 1-D string array")
    if len(set(joint_names.tolist())) != len(joint_names) or not all(joint_names.tolist()):
        raise DictionaryError(f"{path}: joint_names must be distinct, non-empty names")
    meta = parse_meta(meta_text, path, error=DictionaryError, parse_int=_parse_int)
    if isinstance(meta, dict) and "kind" in meta and "alpha_recover" not in meta:
        raise DictionaryError(f"{path}: a {str(meta['kind'])[:40]} file, not a dictionary "
                              "(a lifter goes to `sparseedm lift --lifter`, an FConv model "
                              "to --model)")
    if meta.get("format_version") != FORMAT_VERSION:
        raise DictionaryError(
            f"{path}: dictionary format {meta.get('format_version')!r}, this sparseedm "
            f"reads format {FORMAT_VERSION}"
        )
    _check_meta(meta, str(path))
    _check_components(components, tuple(joint_names), str(path))
    if n_joints is not None and len(joint_names) != n_joints:
        raise DictionaryError(
            f"{path}: dictionary is for {len(joint_names)} joints, the data has {n_joints}"
        )
    try:
        return Dictionary(
            components=components.astype(np.float64),
            joint_names=tuple(str(n) for n in joint_names),
            alpha_recover=float(meta["alpha_recover"]),
            alpha_train=float(meta["alpha_train"]),
            alpha_scaling=meta.get("alpha_scaling", "entries"),
            positive_code=bool(meta.get("positive_code", False)),
            representation=meta.get("representation", "complete"),
            normalization=meta.get("normalization", ""),
            recovery_scale=meta.get("recovery_scale", "box"),
            provenance=meta.get("provenance", {}),
            library_version=meta.get("library_version", "?"),
        )
    except (KeyError, TypeError, ValueError) as exc:
        raise DictionaryError(f"{path}: metadata incomplete or invalid ({exc})") from None


#: caps on a dictionary file's arrays (the shipped one holds 1.5 MB of atoms)
_MAX_BYTES = {"components": 1 << 30, "joint_names": 1 << 20, "meta": 1 << 22}


def _parse_int(text):
    if len(text) > 40:
        raise ValueError(f"an integer of {len(text)} digits")
    return int(text)
