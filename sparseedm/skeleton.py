"""The 14-joint skeleton the paper uses, as one small object.

Other layouts (BVH rigs, CMU ASF/AMC, COCO-17) map onto it by joint name;
see :mod:`sparseedm.mocap` and :mod:`sparseedm.keypoints`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["Skeleton", "SKELETON_14", "JOINT_NAMES", "skeleton_hops"]


@dataclass(frozen=True)
class Skeleton:
    """A kinematic tree of named joints.

    Parameters
    ----------
    joint_names : tuple of str
        Joint names, in the order the joint axis of every array uses.
    parents : tuple of int
        Index of each joint's parent, ``-1`` for the root.
    joints_left, joints_right : tuple of int
        Indices of the left joints and of their right counterparts, pairwise.

    Examples
    --------
    >>> from sparseedm.skeleton import SKELETON_14
    >>> SKELETON_14.num_joints
    14
    >>> SKELETON_14.index("left_wrist")
    7
    >>> SKELETON_14.joint_names[SKELETON_14.parents[7]]
    'left_elbow'
    """

    joint_names: tuple[str, ...]
    parents: tuple[int, ...]
    joints_left: tuple[int, ...] = ()
    joints_right: tuple[int, ...] = ()

    def __post_init__(self):
        n = len(self.joint_names)
        if len(set(self.joint_names)) != n:
            raise ValueError("joint names must be unique")
        if len(self.parents) != n:
            raise ValueError(
                f"parents has {len(self.parents)} entries for {n} joints"
            )
        if any(p < -1 or p >= n for p in self.parents):
            raise ValueError("every parent must be -1 or a joint index")
        if len(self.joints_left) != len(self.joints_right):
            raise ValueError("joints_left and joints_right must pair up")

    @property
    def num_joints(self) -> int:
        """Number of joints N."""
        return len(self.joint_names)

    @property
    def num_distances(self) -> int:
        """Length N(N-1)/2 of the upper-triangle EDM vector."""
        n = self.num_joints
        return n * (n - 1) // 2

    def index(self, name: str) -> int:
        """Index of the joint called `name` (a clear error if unknown)."""
        try:
            return self.joint_names.index(name)
        except ValueError:
            raise KeyError(
                f"unknown joint name {name!r}; known joints: "
                + ", ".join(self.joint_names)
            ) from None

    def bones(self) -> list[tuple[int, int]]:
        """(parent, child) index pairs, one per bone."""
        return [(p, j) for j, p in enumerate(self.parents) if p >= 0]

    def flip_permutation(self) -> np.ndarray:
        """Permutation that swaps every left joint with its right one."""
        perm = np.arange(self.num_joints)
        perm[list(self.joints_left)] = self.joints_right
        perm[list(self.joints_right)] = self.joints_left
        return perm


JOINT_NAMES = (
    "head_top",
    "neck",
    "right_shoulder",
    "right_elbow",
    "right_wrist",
    "left_shoulder",
    "left_elbow",
    "left_wrist",
    "right_hip",
    "right_knee",
    "right_ankle",
    "left_hip",
    "left_knee",
    "left_ankle",
)

#: The paper's 14-joint layout (the LSP/MPII order without pelvis/thorax).
#: The neck is the root; shoulders and hips hang from it.
SKELETON_14 = Skeleton(
    joint_names=JOINT_NAMES,
    parents=(1, -1, 1, 2, 3, 1, 5, 6, 1, 8, 9, 1, 11, 12),
    joints_left=(5, 6, 7, 11, 12, 13),
    joints_right=(2, 3, 4, 8, 9, 10),
)


def skeleton_hops(parents):
    """(N, N) bones between every two joints of the tree `parents`.

    Parameters
    ----------
    parents : sequence of int
        Parent of each joint, -1 at a root.

    Returns
    -------
    ndarray of int (N, N)
        0 on the diagonal; N where two joints are not connected.

    Examples
    --------
    >>> skeleton_hops([-1, 0, 1, 0]).tolist()
    [[0, 1, 2, 1], [1, 0, 1, 2], [2, 1, 0, 3], [1, 2, 3, 0]]
    """
    parents = np.asarray(parents)
    N = len(parents)
    hops = np.full((N, N), N)
    np.fill_diagonal(hops, 0)
    for _ in range(N):
        for j, p in enumerate(parents):
            if p >= 0:
                hops[j] = np.minimum(hops[j], hops[p] + 1)
                hops[p] = np.minimum(hops[p], hops[j] + 1)
    return np.minimum(hops, hops.T)
