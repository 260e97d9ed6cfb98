"""Analytic, sternum-rooted IK: every swivel solution for a wrist position, ranked by strength.

For a wrist position ``w`` (canonical frame) the paper's multi-joint function gives the body
rotation (Table 1, :func:`~reach_addon.core.torso.body_rotation_deg`), which places the
shoulder ``s``. The elbow then lies on a circle about the axis ``s``-``w`` (law of cosines):

.. math::
    d = |w - s|,\\quad \\cos A = \\frac{L_1^2 + d^2 - L_2^2}{2 L_1 d},\\quad
    c = s + L_1 \\cos A\\, \\hat n,\\quad r = L_1 \\sin A,\\\\
    e(φ) = c + r(\\cos φ\\, b_1 + \\sin φ\\, b_2),\\qquad
    \\text{elbow flexion } ε = 180° - \\arccos\\frac{L_1^2 + L_2^2 - d^2}{2 L_1 L_2}

``φ`` (the swivel angle) is sampled every ``Settings.swivel_step`` degrees, starting with
the elbow straight down (``b_1``); every sample becomes a candidate (body rotation, α, β,
γ, ε). A candidate is **legal** inside the joint limits and, when ``Settings.elbow_side``
is ``"require"``, with the elbow on the preferred side of Algorithm 1; it is **valid** if
also within the smoothness bound of the previous configuration. Valid candidates are
ordered by the strength ranking (:func:`~reach_addon.core.strength.rank_order`). Contact
with the body's own capsules is tested by the caller on the candidates it tries
(:func:`self_collision`), in rank order, like obstacle contact.

Vectorised: the upper arm and forearm directions are affine in (cos φ, sin φ), so every
per-sample quantity is a short numpy expression over all samples of all wrists at once.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from . import strength
from .arm import ArmConfig, ArmModel, Pose
from .collision import segment_distance_xyz
from .numeric import ARRAY, SCALAR
from .torso import body_rotation_deg


#: Up to this many valid candidates of one wrist are scored as floats, more as arrays.
_SCALAR_SCORING = 16


@lru_cache(maxsize=16)
def swivel_samples(step_deg: float):
    """cos φ and sin φ, shape (1, S), of the swivel samples 0, step, 2·step, ... < 360°."""
    phi = np.radians(np.arange(0.0, 360.0 - 1e-9, step_deg))
    return np.cos(phi)[None], np.sin(phi)[None]


@lru_cache(maxsize=16)
def swivel_basis(step_deg: float):
    """(1, cos φ, sin φ) stacked, shape (3, S): multiplies affine coefficient matrices."""
    cos_phi, sin_phi = swivel_samples(step_deg)
    return np.concatenate([np.ones_like(cos_phi), cos_phi, sin_phi])


def side_normal(wrist, shoulder, waist, m=ARRAY):
    """Algorithm 1's normal n̂ = normalize[(s - w) × (a - s)] of the plane P through wrist,
    shoulder and waist, from (x, y, z) component tuples (floats with ``m`` = SCALAR, arrays
    with ARRAY). Returns (n_x, n_y, n_z, degenerate): degenerate where P is undefined."""
    px, py, pz = shoulder[0] - wrist[0], shoulder[1] - wrist[1], shoulder[2] - wrist[2]
    qx, qy, qz = waist[0] - shoulder[0], waist[1] - shoulder[1], waist[2] - shoulder[2]
    kx, ky, kz = py * qz - pz * qy, pz * qx - px * qz, px * qy - py * qx
    kn = m.sqrt(kx * kx + ky * ky + kz * kz)
    degenerate = kn < 1e-9
    kn = m.maximum(kn, 1e-12)
    return kx / kn, ky / kn, kz / kn, degenerate


def right_arm_side(wrist, elbow, shoulder, waist):
    """Algorithm 1, RightArmSide(w, e, s, a): True where the elbow lies on the RIGHT side
    of the plane P through wrist, shoulder and waist.

    .. math::
        \\hat n = \\mathrm{normalize}[(s - w) × (a - s)],\\quad
        \\hat p = \\mathrm{normalize}(e - e_P),\\quad
        \\text{RIGHT} \\iff \\hat p = \\hat n

    where ``e_P`` is the projection of ``e`` on P; ``p̂ = n̂`` is tested as
    ``(e - s) · n̂ > 0``. Broadcasts over leading axes of (..., 3) arrays; where P is
    degenerate (wrist, shoulder and waist in a line) every elbow counts as RIGHT. For a
    right arm reaching forward n̂ points outward and down, so RIGHT is the natural,
    elbow-out side; in the canonical frame a left arm is mirrored into a right arm and the
    same rule gives its natural (left) side. (:func:`solve` evaluates the same test for all
    swivel samples at once, with ``e - s`` affine in the swivel angle.)
    """
    w, e, s, a = (np.moveaxis(np.asarray(v, dtype=float), -1, 0) for v in (wrist, elbow,
                                                                         shoulder, waist))
    nx, ny, nz, degenerate = side_normal(w, s, a)
    return ((e[0] - s[0]) * nx + (e[1] - s[1]) * ny + (e[2] - s[2]) * nz > 0) | degenerate


def _cross(a, b):
    """Cross product of vectors stored as component tuples (broadcasting)."""
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


@dataclass
class Solutions:
    """All swivel samples for W wrist positions. Per-sample arrays are (W, S); per-wrist
    arrays are (W,) or (W, 3). Elbow positions and forearm directions are kept as affine
    coefficients in (cos φ, sin φ) and built only for the candidates asked for."""

    wrists: np.ndarray       # (W, 3)
    body: np.ndarray         # (W,)
    sternum: np.ndarray      # (W, 3)
    shoulder: np.ndarray     # (W, 3)
    elbow_coef: np.ndarray   # (W, 3, 3): centre, r·b1, r·b2
    fore_coef: np.ndarray    # (W, 3, 3): unit forearm direction = F0 + F1 cos φ + F2 sin φ
    cos_phi: np.ndarray      # (S,)
    sin_phi: np.ndarray      # (S,)
    bend: np.ndarray         # (W, 3, S), canonical unit bend direction
    alpha: np.ndarray        # (W, S)
    beta: np.ndarray         # (W, S)
    gamma: np.ndarray        # (W, S)
    flex: np.ndarray         # (W,)
    reachable: np.ndarray    # (W,)
    legal: np.ndarray        # (W, S): reachable, in the joint limits, elbow side if required
    valid: np.ndarray        # (W, S): legal and within the smoothness bound
    f_r: np.ndarray          # (W, S), filled where valid
    second: np.ndarray       # (W, S), filled where valid
    wrong_side: np.ndarray   # (W, S)
    hand_length: float

    def order(self, i: int, elbow_side: str) -> np.ndarray:
        """Indices of wrist ``i``'s valid candidates, best first."""
        idx = np.flatnonzero(self.valid[i])
        if idx.size <= 1:
            return idx
        first = self.wrong_side[i, idx] if elbow_side == "prefer" else None
        return idx[strength.rank_order(self.f_r[i, idx], self.second[i, idx], first)]

    def joints(self, i: int, k) -> np.ndarray:
        """Joint positions (len(k), 5, 3) of candidates ``k`` of wrist ``i`` (canonical)."""
        k = np.atleast_1d(k)
        basis = np.stack([np.ones(len(k)), self.cos_phi[k], self.sin_phi[k]], 1)  # (n, 3)
        elbow = basis @ self.elbow_coef[i]
        fore = basis @ self.fore_coef[i]
        out = np.empty((len(k), 5, 3))
        out[:, 0] = self.sternum[i]
        out[:, 1] = self.shoulder[i]
        out[:, 2] = elbow
        out[:, 3] = self.wrists[i]
        out[:, 4] = self.wrists[i] + self.hand_length * fore
        return out

    def config(self, i: int, k: int) -> ArmConfig:
        return ArmConfig(float(self.body[i]), float(self.alpha[i, k]), float(self.beta[i, k]),
                         float(self.gamma[i, k]), float(self.flex[i]))

    def pose(self, i: int, k: int, joints=None, hand=(0.0, 0.0)) -> Pose:
        if joints is None:
            joints = self.joints(i, k)[0]
        bend = self.bend[i, :, k].copy()
        return Pose(self.config(i, k), joints, bend, int(self.f_r[i, k]), hand)


def solve(arm: ArmModel, wrists, settings, previous: ArmConfig | None = None,
          body_rotation=None, max_change: float | None = None) -> Solutions:
    """Every swivel solution for each wrist position (W, 3), canonical frame.

    ``previous`` is the configuration the move starts from: f_E is measured from it and,
    with ``max_change`` (degrees), the smoothness bound is applied against it. Without
    ``previous`` the exertion is measured from the hanging arm (α = β = γ = 0) and a
    straight elbow gets twist 0. ``body_rotation`` overrides Table 1 (used when a path is
    timed with phased chest rotation).
    """
    st = settings
    w = np.atleast_2d(np.asarray(wrists, dtype=float))
    n_w = len(w)
    cos_phi, sin_phi = swivel_samples(float(st.swivel_step))

    # --- per wrist: plain floats for one wrist, arrays for many ---------------------
    if n_w == 1:
        m = SCALAR
        wx, wy, wz = (float(v) for v in w[0])
        if body_rotation is None:
            body = float(body_rotation_deg(w[0], arm.arm_length, st))
        else:
            body = float(np.asarray(body_rotation, dtype=float).reshape(-1)[0])
    else:
        m = ARRAY
        wx, wy, wz = w[:, 0], w[:, 1], w[:, 2]
        if body_rotation is None:
            body = np.asarray(body_rotation_deg(w, arm.arm_length, st), dtype=float)
        else:
            body = np.broadcast_to(np.asarray(body_rotation, dtype=float), (n_w,)).copy()
    t = _wrist_terms(arm, wx, wy, wz, body, st, m)
    body = np.atleast_1d(np.asarray(body, dtype=float))
    shoulder, sternum = _rows(t["shoulder"], n_w), _rows(t["sternum"], n_w)
    reachable = np.atleast_1d(np.asarray(t["reachable"], dtype=bool))
    elbow_coef = _rows(t["elbow_coef"], n_w)                             # (W, 3, 3)
    fore_coef = _rows(t["fore_coef"], n_w)
    upper_coef = _rows(t["upper_coef"], n_w)
    to_chest = _rows(t["to_chest"], n_w)
    side_coef = _rows(t["side_coef"], n_w)                               # (W, 3)
    cos_eps = np.atleast_1d(np.asarray(t["cos_eps"], dtype=float))[:, None]
    sin_eps = np.atleast_1d(np.asarray(t["sin_eps"], dtype=float))[:, None]
    flex = np.atleast_1d(np.asarray(t["flex"], dtype=float))
    degenerate = np.atleast_1d(np.asarray(t["degenerate"], dtype=bool))[:, None]

    # --- per sample: (W, 3, S) in the chest frame --------------------------------------
    basis = swivel_basis(float(st.swivel_step))                          # (3, S)
    u = to_chest @ (upper_coef.transpose(0, 2, 1) @ basis)               # (W, 3, S)
    f = to_chest @ (fore_coef.transpose(0, 2, 1) @ basis)
    ux, uy, uz = u[:, 0], u[:, 1], u[:, 2]

    # Shoulder angles (α, β) = θ·(u_x, u_y)/|(u_x, u_y)|, θ = acos(-u_z).
    theta = np.degrees(np.arccos(np.minimum(np.maximum(-uz, -1.0), 1.0)))
    h = np.sqrt(ux * ux + uy * uy)
    scale = theta / np.maximum(h, 1e-12)
    alpha, beta = scale * ux, scale * uy

    # Twist γ: signed angle about -u from the swing reference to the bend direction.
    k = 1.0 / np.maximum(1.0 - uz, 1e-12)
    ref = (-ux * uy * k, -uz + ux * ux * k, uy)
    gamma_prev = 0.0 if previous is None else previous.gamma
    straight = sin_eps[:, 0] < 1e-6
    bend = (f - cos_eps[:, :, None] * u) / np.where(straight, 1.0, sin_eps[:, 0])[:, None, None]
    bx, by, bz = bend[:, 0], bend[:, 1], bend[:, 2]
    gamma = np.degrees(np.arctan2(
        -(ref[0] * (by * uz - bz * uy) + ref[1] * (bz * ux - bx * uz) + ref[2] * (bx * uy - by * ux)),
        ref[0] * bx + ref[1] * by + ref[2] * bz))
    if straight.any():
        # A straight elbow shows no twist: keep the previous one.
        g = np.radians(gamma_prev)
        turned = _cross(tuple(-c for c in (ux, uy, uz)), ref)
        kept = np.stack([ref[j] * np.cos(g) + turned[j] * np.sin(g) for j in range(3)], 1)
        bend = np.where(straight[:, None, None], kept, bend)
        gamma = np.where(straight[:, None], gamma_prev, gamma)
    bend_canonical = to_chest.transpose(0, 2, 1) @ bend                  # (W, 3, S)

    # --- legality ---------------------------------------------------------------------
    wrist_ok = reachable & (flex >= st.elbow_min) & (flex <= st.elbow_max)
    legal = ((alpha >= st.alpha_min) & (alpha <= st.alpha_max) & (beta >= st.beta_min)
             & (beta <= st.beta_max) & (theta <= st.elevation_max)
             & (gamma >= st.gamma_min) & (gamma <= st.gamma_max)) & wrist_ok[:, None]
    # Algorithm 1: side = (e - s)·n̂, affine in (cos φ, sin φ) like e.
    side = side_coef @ basis                                             # (W, S)
    wrong_side = ~((side > 0) | degenerate)
    if st.elbow_side == "require":
        legal &= ~wrong_side

    valid = legal
    if previous is not None and max_change is not None:
        valid = legal & smooth(previous, body, alpha, beta, gamma, flex, max_change)

    prev_angles = (0.0, 0.0, 0.0) if previous is None else (
        previous.alpha, previous.beta, previous.gamma)
    if n_w == 1 and valid.sum() <= _SCALAR_SCORING:
        # Few candidates to rank: score them as floats (a numpy call costs ~1 µs each).
        f_r = np.zeros(alpha.shape, dtype=np.int8)
        second = np.zeros(alpha.shape)
        for k in np.flatnonzero(valid[0]).tolist():
            f_r[0, k], second[0, k] = strength.scores(
                float(alpha[0, k]), float(beta[0, k]), float(gamma[0, k]), prev_angles, st)
    else:
        f_r, second = strength.scores(alpha, beta, gamma, prev_angles, st)
    return Solutions(w, body, sternum, shoulder, elbow_coef, fore_coef, cos_phi[0], sin_phi[0],
                     bend_canonical, alpha, beta, gamma, flex, reachable, legal, valid, f_r,
                     second, wrong_side, arm.hand_length)


def _rows(value, n_w):
    """Nested lists of floats (one wrist) or of (W,) arrays → an array with W first."""
    a = np.asarray(value, dtype=float)
    return a[None] if n_w == 1 else np.moveaxis(a, -1, 0)


def _wrist_terms(arm: ArmModel, wx, wy, wz, body, st, m):
    """Everything about one wrist position that does not depend on the swivel angle,
    written once for floats (``m`` = SCALAR) and for arrays of wrists (``m`` = ARRAY)."""
    l1, l2 = arm.upper_arm_length, arm.forearm_length
    rad = m.radians(body)
    cb, sb = m.cos(rad), m.sin(rad)
    s0x, s0y, s0z = (float(v) for v in arm.shoulder)
    sx, sy, sz = cb * s0x + sb * s0y, cb * s0y - sb * s0x, s0z + 0.0 * cb
    t0x, t0y, t0z = (float(v) for v in arm.sternum)
    dx, dy, dz = wx - sx, wy - sy, wz - sz
    d = m.sqrt(dx * dx + dy * dy + dz * dz)
    tol = 1e-9 * arm.arm_length
    reachable = (d <= l1 + l2 + tol) & (d >= arm.min_reach(st.elbow_max) - tol) & (d > tol)
    d = m.maximum(d, 1e-12)
    nx, ny, nz = dx / d, dy / d, dz / d
    cos_a = m.clip((l1 * l1 + d * d - l2 * l2) / (2 * l1 * d), -1.0, 1.0)
    r = l1 * m.sqrt(1.0 - cos_a * cos_a)
    cx, cy, cz = sx + nx * l1 * cos_a, sy + ny * l1 * cos_a, sz + nz * l1 * cos_a
    # b1: "elbow down" ⊥ axis, ((0,0,-1) + n_z n) / √(1 - n_z²) = (n_z n_x, n_z n_y, -h²)/h
    # with h² = n_x² + n_y² (no cancellation near vertical); sideways if the axis is
    # vertical. b2 = n × b1.
    hz = m.sqrt(nx * nx + ny * ny)
    vertical = hz < 1e-9
    hz = m.maximum(hz, 1e-12)
    lx, ly, lz = 1.0 - nx * nx, -nx * ny, -nx * nz
    ln = m.maximum(m.sqrt(lx * lx + ly * ly + lz * lz), 1e-12)
    b1x = m.where(vertical, lx / ln, nz * nx / hz)
    b1y = m.where(vertical, ly / ln, nz * ny / hz)
    b1z = m.where(vertical, lz / ln, -hz)
    b2x, b2y, b2z = ny * b1z - nz * b1y, nz * b1x - nx * b1z, nx * b1y - ny * b1x
    rb1 = [r * b1x, r * b1y, r * b1z]
    rb2 = [r * b2x, r * b2y, r * b2z]
    cos_eps = m.clip((d * d - l1 * l1 - l2 * l2) / (2 * l1 * l2), -1.0, 1.0)   # u·f = cos ε
    # Algorithm 1: side = (e - s)·n̂, affine in (cos φ, sin φ) like e.
    kx, ky, kz, degenerate = side_normal((wx, wy, wz), (sx, sy, sz),
                                         tuple(float(v) for v in arm.waist), m)
    zero, one = 0.0 * cb, 1.0 + 0.0 * cb
    return {
        "shoulder": [sx, sy, sz],
        "sternum": [cb * t0x + sb * t0y, cb * t0y - sb * t0x, t0z + zero],
        "reachable": reachable,
        "elbow_coef": [[cx, cy, cz], rb1, rb2],
        "fore_coef": [[(wx - cx) / l2, (wy - cy) / l2, (wz - cz) / l2],
                      [-v / l2 for v in rb1], [-v / l2 for v in rb2]],
        "upper_coef": [[(cx - sx) / l1, (cy - sy) / l1, (cz - sz) / l1],
                       [v / l1 for v in rb1], [v / l1 for v in rb2]],
        # Canonical → chest frame: x' = c x - s y, y' = s x + c y.
        "to_chest": [[cb, -sb, zero], [sb, cb, zero], [zero, zero, one]],
        "side_coef": [(cx - sx) * kx + (cy - sy) * ky + (cz - sz) * kz,
                      rb1[0] * kx + rb1[1] * ky + rb1[2] * kz,
                      rb2[0] * kx + rb2[1] * ky + rb2[2] * kz],
        "cos_eps": cos_eps,
        "sin_eps": m.sqrt(1.0 - cos_eps * cos_eps),
        "flex": m.degrees(m.acos(cos_eps)),
        "degenerate": degenerate,
    }


def wrap_degrees(angle):
    """Angle difference folded into [-180°, 180°)."""
    return (np.asarray(angle) + 180.0) % 360.0 - 180.0


def smooth(previous: ArmConfig, body, alpha, beta, gamma, flex, max_change):
    """The smoothness bound: no joint angle changes by more than ``max_change`` degrees from
    ``previous``. Shapes: ``body``/``flex`` (W,), the shoulder angles (W, S). The twist
    counts in proportion to elbow flexion up to 20° (a nearly straight elbow hides its
    twist, which is then free to settle)."""
    flex = np.asarray(flex)
    wrist_ok = ((np.abs(flex - previous.elbow) <= max_change)
                & (np.abs(np.asarray(body) - previous.body_rotation) <= max_change))[:, None]
    twist_limit = (max_change / np.maximum(np.minimum(flex / 20.0, 1.0), 1e-9))[:, None]
    return (wrist_ok & (np.abs(alpha - previous.alpha) <= max_change)
            & (np.abs(beta - previous.beta) <= max_change)
            & (np.abs(wrap_degrees(gamma - previous.gamma)) <= twist_limit))


def body_capsules_at(arm: ArmModel, body: float):
    """The body's capsules with the chest turned by ``body`` degrees, as float tuples
    (a, b, centre, half length, radius) for quick scalar tests."""
    a, b, cap_r = arm.capsules_at(float(body))
    return [(p, q, [0.5 * (p[i] + q[i]) for i in range(3)], 0.5 * math.dist(p, q), r)
            for p, q, r in zip(a.tolist(), b.tolist(), cap_r.tolist())]


def segment_hits_body(p, q, radius, capsules) -> bool:
    """Does the capsule p-q (float 3-sequences) of ``radius`` pass through one of
    ``capsules`` (from :func:`body_capsules_at`)? Bounding spheres first."""
    mid = [0.5 * (p[i] + q[i]) for i in range(3)]
    half = 0.5 * math.dist(p, q)
    for ca, cb, cmid, chalf, cr in capsules:
        if math.dist(mid, cmid) < half + chalf + radius + cr and \
                segment_distance_xyz(p, q, ca, cb) < radius + cr:
            return True
    return False


def self_collision(arm: ArmModel, body: float, joints, include_hand: bool = True) -> np.ndarray:
    """True for each candidate (joints (n, 5, 3), canonical, one chest rotation ``body``)
    whose forearm, hand (if ``include_hand``) or elbow half of the upper arm passes through
    one of the body's own capsules (chest and head turn with the chest rotation). The upper
    arm's half nearest the shoulder is not tested: it is attached to the torso there."""
    joints = np.asarray(joints, dtype=float)
    out = np.zeros(len(joints), dtype=bool)
    if not arm.body_capsules:
        return out
    caps = body_capsules_at(arm, body)
    for n, (_st, sh, el, wr, ha) in enumerate(joints.tolist()):
        mid_upper = [0.5 * (sh[i] + el[i]) for i in range(3)]
        out[n] = (segment_hits_body(mid_upper, el, arm.upper_arm_radius, caps)
                  or segment_hits_body(el, wr, arm.forearm_radius, caps)
                  or (include_hand and segment_hits_body(wr, ha, arm.hand_radius, caps)))
    return out
