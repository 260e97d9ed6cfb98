"""A lean posed on a rig (:mod:`.lean`): its pivot, the lean bone's channel matrices, and the
hips' shift with it, posed as the balance check, the lower body's test and the bake pose it.

**Posing** (:func:`lean_basis`): a lean is a rotation of the lean bone's pose matrix ``M``
about its head, ``M' = T_h R T_h⁻¹ M``; its channel (basis) matrix is then
``B' = B M⁻¹ M'``, whatever the bone's parents, rotation mode or roll.
"""

from __future__ import annotations

import numpy as np
from mathutils import Matrix

from . import hips as hips_mod


def pivot_world(armature, bone: str) -> np.ndarray:
    """The lean bone's head now (world): the lean's pivot."""
    mw = np.array(armature.matrix_world)
    return mw[:3, :3] @ np.array(armature.pose.bones[bone].head) + mw[:3, 3]


def lean_basis(armature, bone: str, rotations_world) -> np.ndarray:
    """The lean bone's channel (basis) matrices (F, 4, 4) for the world rotations
    ``rotations_world`` (F, 3, 3) of the trunk about its head, from its pose now (see the
    module docstring)."""
    pb = armature.pose.bones[bone]
    a = np.array(armature.matrix_world)[:3, :3]
    a_inv = np.linalg.inv(a)
    m = np.array(pb.matrix)
    basis = np.array(pb.matrix_basis)
    m_inv = np.linalg.inv(m)
    out = []
    for r in np.asarray(rotations_world, dtype=float):
        leaned = m.copy()
        leaned[:3, :3] = a_inv @ r @ a @ m[:3, :3]
        out.append(basis @ m_inv @ leaned)
    return np.array(out)


def world_rotations(info, lean, fractions) -> np.ndarray:
    """The trunk's world rotations (F, 3, 3) at ``fractions`` of ``lean``: the canonical
    lean (:meth:`~..core.lean.Lean.matrix`) carried into the world, ``M R M⁻¹`` with ``M``
    the arm's canonical-to-world rotation (a mirror for a left arm)."""
    m = np.asarray(info.arm.to_world, dtype=float)[:3, :3]
    return np.array([m @ lean.matrix(f)[:3, :3] @ m.T for f in fractions])


def shift_world(info, lean, fraction: float = 1.0) -> np.ndarray:
    """The hips' shift of ``lean`` (canonical) in the world, at ``fraction`` of the lean
    (:meth:`~..core.lean.Lean.shift_at`)."""
    return np.asarray(info.arm.to_world, dtype=float)[:3, :3] @ lean.shift_at(fraction)


def pose_lean(context, armature, bone: str, basis) -> None:
    """Set the lean bone's channel matrix to ``basis`` (4, 4) and evaluate."""
    armature.pose.bones[bone].matrix_basis = Matrix(np.asarray(basis).tolist())
    context.view_layer.update()


def pose_leaned(context, armature, info, bone: str, basis, legs=(), hips=None,
                shift=None) -> None:
    """Pose the lean bone at ``basis`` and, where ``hips`` is given, the hips moved by the
    world ``shift`` with the feet planted (:func:`.hips.pose_shift`): the one way the
    balance, the lower body's test and the bake pose a lean."""
    pose_lean(context, armature, bone, basis)
    if hips is not None:
        hips_mod.pose_shift(context, armature, list(legs), hips, shift,
                            np.asarray(info.frame.ground, float),
                            np.asarray(info.frame.forward, float))
