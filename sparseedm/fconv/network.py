"""The FConv network: two convolutions and two deconvolutions on an N x N EDM.

Reading of the architecture
---------------------------
Guo & Dai compare sparse coding with "FConv", the fully convolutional
regressor of DMR (F. Moreno-Noguer, "3D Human Pose Estimation from a Single
Image via Distance Matrix Regression", CVPR 2017, sec. 4, "Fully
Convolutional" network): an encoder of two convolution layers and a decoder
of two deconvolution (transposed convolution) layers that maps an N x N
distance matrix to an N x N distance matrix. Neither paper's text at hand
gives every filter size, so the sizes below are this package's reading,
stated so that they can be checked and changed (``channels``, ``kernel``):

======== ================================ ======================== ==========
layer    operation                        channels                 N=14 map
======== ================================ ======================== ==========
input    the N x N EDM, one channel       1                        14 x 14
enc1     conv k x k, stride 2, pad k//2   1 -> C1, ReLU            7 x 7
enc2     conv k x k, stride 2, pad k//2   C1 -> C2, ReLU           4 x 4
dec1     deconv k x k, stride 2           C2 -> C1, ReLU           7 x 7
dec2     deconv k x k, stride 2           C1 -> 1 (linear)         14 x 14
sym      optional: (Y + Y^T) / 2          1                        14 x 14
======== ================================ ======================== ==========

with ``C1, C2 = 32, 64`` and ``k = 3`` by default; the deconvolutions'
output paddings are chosen so that the decoder returns exactly the encoder's
input sizes for any N. DMR enforces symmetry of the predicted matrix by
construction; Guo & Dai's FConv omits that layer, so it is an option here
(``symmetrize``) and the evaluation measures both. Outputs are clamped at 0
when read (a distance is never negative).

This module is the only one that builds torch objects; it imports torch only
inside its functions (:func:`require_torch`).
"""

from __future__ import annotations

from ..exceptions import SparseEDMError

__all__ = ["require_torch", "param_shapes", "build_network", "spatial_sizes"]

#: the layers, in order: (name, kind)
LAYERS = (("enc1", "conv"), ("enc2", "conv"), ("dec1", "deconv"), ("dec2", "deconv"))


def require_torch():
    """Import torch or say how to install it.

    Returns
    -------
    module
        The imported ``torch`` package.

    Raises
    ------
    SparseEDMError
        PyTorch is not installed; the message gives the install commands.
    """
    try:
        import torch
    except ImportError:
        raise SparseEDMError(
            "the FConv network needs PyTorch: on a CPU machine run "
            "`pip install torch==2.13.0` first, then `pip install 'sparseedm[torch]'`"
        ) from None
    return torch


def spatial_sizes(n_joints, kernel=3):
    """Map sizes through the encoder: ``[N, after enc1, after enc2]``.

    Examples
    --------
    >>> spatial_sizes(14)
    [14, 7, 4]
    """
    sizes = [int(n_joints)]
    for _ in range(2):
        sizes.append((sizes[-1] + 2 * (kernel // 2) - kernel) // 2 + 1)
    return sizes


def output_paddings(n_joints, kernel):
    s = spatial_sizes(n_joints, kernel)
    pads = []
    for src, dst in ((s[2], s[1]), (s[1], s[0])):
        pads.append(dst - ((src - 1) * 2 - 2 * (kernel // 2) + kernel))
    if any(p not in (0, 1) for p in pads):
        raise SparseEDMError(f"kernel {kernel} cannot map {n_joints} joints back to {n_joints}")
    return pads


def param_shapes(channels=(32, 64), kernel=3, in_channels=1):
    """Names and shapes of the parameters (torch's layout), without torch.

    Examples
    --------
    >>> param_shapes((4, 8))["enc2.weight"], param_shapes((4, 8))["dec1.weight"]
    ((8, 4, 3, 3), (8, 4, 3, 3))
    """
    c1, c2 = (int(c) for c in channels)
    k = int(kernel)
    io = {"enc1": (in_channels, c1), "enc2": (c1, c2), "dec1": (c2, c1), "dec2": (c1, 1)}
    out = {}
    for name, kind in LAYERS:
        i, o = io[name]
        out[f"{name}.weight"] = (o, i, k, k) if kind == "conv" else (i, o, k, k)
        out[f"{name}.bias"] = (o,)
    return out


def build_network(n_joints, channels=(32, 64), kernel=3, symmetrize=False):
    """The FConv module: (batch, 1, N, N) -> (batch, 1, N, N)."""
    torch = require_torch()
    nn = torch.nn
    c1, c2 = (int(c) for c in channels)
    k, pad = int(kernel), int(kernel) // 2
    op1, op2 = output_paddings(n_joints, k)

    class FConv(nn.Module):
        def __init__(self):
            super().__init__()
            self.enc1 = nn.Conv2d(1, c1, k, stride=2, padding=pad)
            self.enc2 = nn.Conv2d(c1, c2, k, stride=2, padding=pad)
            self.dec1 = nn.ConvTranspose2d(c2, c1, k, stride=2, padding=pad, output_padding=op1)
            self.dec2 = nn.ConvTranspose2d(c1, 1, k, stride=2, padding=pad, output_padding=op2)
            self.symmetrize = bool(symmetrize)

        def forward(self, x):
            relu = torch.relu
            y = self.dec2(relu(self.dec1(relu(self.enc2(relu(self.enc1(x)))))))
            if self.symmetrize:
                y = 0.5 * (y + y.transpose(-1, -2))
            return y

    return FConv()
