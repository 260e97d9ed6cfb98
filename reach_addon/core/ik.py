"""Analytic, sternum-rooted IK: every swivel solution for a wrist position, ranked by strength.

For a wrist position ``w`` (canonical frame) Table 1 gives the body rotation
(:func:`~reach_addon.core.torso.body_rotation_deg`), which places the shoulder ``s``. The
elbow then lies on a circle about the axis ``s``-``w`` (law of cosines):

.. math::
    d = |w - s|,\\quad \\cos A = \\frac{L_1^2 + d^2 - L_2^2}{2 L_1 d},\\quad
    c = s + L_1 \\cos A\\, \\hat n,\\quad r = L_1 \\sin A,\\\\
    e(φ) = c + r(\\cos φ\\, b_1 + \\sin φ\\, b_2),\\qquad
    \\text{elbow flexion } ε = 180° - \\arccos\\frac{L_1^2 + L_2^2 - d^2}{2 L_1 L_2}

The swivel angle ``φ`` is sampled every ``Settings.swivel_step`` degrees from the elbow
straight down (``b_1``); each sample is a candidate (body rotation, α, β, γ, ε). It is
**legal** inside the joint limits and, with ``Settings.elbow_side`` "require", on
Algorithm 1's side (:mod:`~reach_addon.core.limits`); **valid** if also within the
smoothness bound of the previous configuration. Valid candidates are ordered by the
strength ranking (:func:`~reach_addon.core.strength.rank_order`); callers test them
against the obstacles and the body in that order.
"""

from __future__ import annotations

import math
from typing import NamedTuple
from functools import lru_cache

import numpy as np

from . import strength
from .arm import ArmConfig, ArmModel, Pose
from .limits import (STRAIGHT, move_limits, on_elbow_side, settings_limits, side_normal,
                     smooth_angles, valid_bounds)
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
def swivel_lists(step_deg: float):
    """cos φ and sin φ of the swivel samples as lists of floats (for scalar code)."""
    cos_phi, sin_phi = swivel_samples(step_deg)
    return cos_phi[0].tolist(), sin_phi[0].tolist()


@lru_cache(maxsize=16)
def swivel_basis(step_deg: float):
    """(1, cos φ, sin φ) stacked, shape (3, S): multiplies affine coefficient matrices."""
    cos_phi, sin_phi = swivel_samples(step_deg)
    return np.concatenate([np.ones_like(cos_phi), cos_phi, sin_phi])



class Solutions:
    """All swivel samples for W wrist positions. Per-sample arrays are (W, S); per-wrist
    arrays are (W,) or (W, 3). Elbow positions and forearm directions are kept as affine
    coefficients in (cos φ, sin φ) and built only for the candidates asked for.

    The angles of a wrist the arm cannot reach (:attr:`reachable` false, or an elbow
    flexion outside its limits) are NaN: there is no arm pose to measure them on.
    :attr:`legal` is worked out when first asked for (the planner's inner loop only needs
    :attr:`valid`)."""

    __slots__ = ("wrists", "body", "sternum", "shoulder", "elbow_coef", "fore_coef", "cos_phi",
                 "sin_phi", "angles", "flex", "_reachable", "valid", "_f_r", "_second",
                 "wrong_side", "hand_length", "_upper", "_fore", "_turn", "_eps", "_gamma_prev",
                 "_limits", "_require_side", "_legal", "_ranked")

    def __init__(self, *, wrists, body, sternum, shoulder, elbow_coef, fore_coef, cos_phi,
                 sin_phi, angles, flex, reachable, valid, f_r, second, wrong_side,
                 hand_length, upper, fore, turn, eps, gamma_prev, limits, require_side,
                 legal=None, ranked=None):
        self.wrists = wrists            # (W, 3)
        self.body = body                # (W,)
        self.sternum = sternum          # (W, 3)
        self.shoulder = shoulder        # (W, 3)
        self.elbow_coef = elbow_coef    # (W, 3, 3): centre, r·b1, r·b2
        self.fore_coef = fore_coef      # (W, 3, 3): unit forearm direction, F0 + F1 cos φ + F2 sin φ
        self.cos_phi = cos_phi          # (S,)
        self.sin_phi = sin_phi          # (S,)
        self.angles = angles            # (W, 4, S): α, β, γ and the elevation θ
        self.flex = flex                # (W,)
        self._reachable = reachable     # (W,) or a bool for one wrist
        self.valid = valid              # (W, S): legal and within the smoothness bound
        # (W, S) arrays filled where valid, or for one wrist lists (made arrays when asked)
        self._f_r, self._second = f_r, second
        self.wrong_side = wrong_side    # (W, S)
        self.hand_length = hand_length
        # chest-frame upper arm and forearm directions (W, 3, S), the chest turn (W, 2) as
        # cos/sin and (cos ε, sin ε) (W, 2): bend directions are built from them on demand
        self._upper, self._fore, self._turn, self._eps = upper, fore, turn, eps
        self._gamma_prev = gamma_prev
        self._limits = limits
        self._require_side = require_side
        self._legal = legal
        self._ranked = ranked           # (elbow side rule, [k best first]) of wrist 0

    @property
    def f_r(self) -> np.ndarray:
        """(W, S) strength category f_R of the valid candidates (0 elsewhere)."""
        if isinstance(self._f_r, list):
            self._f_r = np.array([self._f_r], dtype=np.int8)
        return self._f_r

    @property
    def second(self) -> np.ndarray:
        """(W, S) second-level score of the valid candidates (0 elsewhere)."""
        if isinstance(self._second, list):
            self._second = np.array([self._second])
        return self._second

    def category(self, i: int, k: int) -> int:
        """f_R of candidate ``k`` of wrist ``i``."""
        if i == 0 and isinstance(self._f_r, list):
            return self._f_r[k]
        return int(self.f_r[i, k])

    @property
    def reachable(self) -> np.ndarray:
        """(W,): the wrist is within reach with the elbow inside its limits."""
        return np.atleast_1d(np.asarray(self._reachable, dtype=bool))

    @property
    def alpha(self) -> np.ndarray:
        return self.angles[:, 0]

    @property
    def beta(self) -> np.ndarray:
        return self.angles[:, 1]

    @property
    def gamma(self) -> np.ndarray:
        return self.angles[:, 2]

    @property
    def legal(self) -> np.ndarray:
        """(W, S): reachable, inside the joint limits, the elbow on its side if required."""
        if self._legal is None:
            lo, hi = self._limits
            legal = np.logical_and.reduce((self.angles >= lo) & (self.angles <= hi), 1)
            self._legal = legal & ~self.wrong_side if self._require_side else legal
        return self._legal

    def ranked(self, i: int, elbow_side: str) -> list:
        """Indices of wrist ``i``'s valid candidates, best first, as a list."""
        if i == 0 and self._ranked is not None and self._ranked[0] == elbow_side:
            return list(self._ranked[1])
        return self.order(i, elbow_side).tolist()

    def order(self, i: int, elbow_side: str) -> np.ndarray:
        """Indices of wrist ``i``'s valid candidates, best first: the key of
        :func:`~reach_addon.core.strength.rank_order` (a few candidates are sorted as
        Python tuples, which is the same order and cheaper than numpy for short lists).
        The elbow's side leads the key under "prefer", and under "require" too where the
        move starts off the side (:func:`solve` lets it come back; elsewhere every valid
        candidate is on the side and the key changes nothing)."""
        if i == 0 and self._ranked is not None and self._ranked[0] == elbow_side:
            return np.array(self._ranked[1], dtype=np.intp)
        idx = np.flatnonzero(self.valid[i])
        if idx.size <= 1:
            return idx
        sided = elbow_side == "prefer" or (elbow_side == "require" and not self._require_side)
        if idx.size <= _SCALAR_SCORING:
            return np.array(_rank(idx.tolist(), self.f_r[i].tolist(), self.second[i].tolist(),
                                  self.wrong_side[i].tolist() if sided else None),
                            dtype=idx.dtype)
        first = self.wrong_side[i, idx] if sided else None
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

    def bend_at(self, i: int, k: int) -> np.ndarray:
        """Unit direction (3,), canonical frame, that candidate ``k`` of wrist ``i``'s
        forearm bends toward: (f - cos ε u) / sin ε; with a straight elbow, the direction
        of the kept twist (see :func:`solve`)."""
        ux, uy, uz = self._upper[i, :, k].tolist()
        ce, se = self._eps[i].tolist()
        if se < STRAIGHT:
            a = ux / max(1.0 - uz, 1e-12)
            g = math.radians(self._gamma_prev)
            cg, sg = math.cos(g), math.sin(g)
            # reference r = (-a u_y, a u_x - u_z, u_y), turned by γ about -u: r cos γ - t sin γ
            # with t = u × r = (1 - a u_x, -a u_y, u_x)
            bx = -a * uy * cg - (1.0 - a * ux) * sg
            by = (a * ux - uz) * cg + a * uy * sg
            bz = uy * cg - ux * sg
        else:
            fx, fy, fz = self._fore[i, :, k].tolist()
            bx, by, bz = (fx - ce * ux) / se, (fy - ce * uy) / se, (fz - ce * uz) / se
        cb, sb = self._turn[i].tolist()
        return np.array([cb * bx + sb * by, cb * by - sb * bx, bz])

    def config(self, i: int, k: int) -> ArmConfig:
        a, b, g, _t = self.angles[i, :, k].tolist()
        return ArmConfig(float(self.body[i]), a, b, g, float(self.flex[i]))

    def pose(self, i: int, k: int, joints=None, hand=(0.0, 0.0)) -> Pose:
        if joints is None:
            joints = self.joints(i, k)[0]
        return Pose(self.config(i, k), joints, self.bend_at(i, k), self.category(i, k), hand)


def _rank(ks: list, f_r: list, second: list, wrong: list | None) -> list:
    """Candidate indices ``ks`` sorted as :func:`~reach_addon.core.strength.rank_order`
    sorts them (wrong side first key if given, then f_R, the second-level score, the
    index)."""
    if wrong is None:
        return sorted(ks, key=lambda k: (f_r[k], second[k], k))
    return sorted(ks, key=lambda k: (wrong[k], f_r[k], second[k], k))


def solve(arm: ArmModel, wrists, settings, previous: ArmConfig | None = None,
          body_rotation=None, max_change: float | None = None) -> Solutions:
    """Every swivel solution for each wrist position of ``wrists`` (W, 3), canonical frame:
    per sample the angles (α, β, γ and the elevation θ, degrees), whether it is legal and
    valid, and the strength category f_R and second-level score of the valid ones
    (:class:`Solutions`).

    ``previous``: the configuration the move starts from. f_E is measured from it and, with
    ``max_change`` (degrees), the smoothness bound is applied against it and the joint
    limits are widened to take it in (:mod:`~reach_addon.core.limits`). Without
    ``previous`` f_E is measured from the hanging arm (α = β = γ = 0) and a straight elbow
    gets twist 0. ``body_rotation`` (degrees; a float, or (W,)) overrides Table 1's chest
    rotation.

    Stages: the chest rotation and everything that does not depend on the swivel angle
    (:func:`_wrist_terms`), every sample's angles at once (:func:`_sample_angles`), then
    validity and ranking: on floats for one wrist, the planner's inner loop
    (:func:`_rank_one`), on arrays for many (:func:`_validate_many`)."""
    st = settings
    w = np.atleast_2d(np.asarray(wrists, dtype=float))
    one = len(w) == 1
    m = SCALAR if one else ARRAY
    smooth_bound = previous is not None and max_change is not None
    limits = move_limits(st, previous) if smooth_bound else settings_limits(st)
    e_lo, e_hi, require = _elbow_rules(arm, st, previous, smooth_bound)

    # per wrist: plain floats for one wrist, arrays for many
    body = _body_rotation(arm, w, st, body_rotation, one)
    wx, wy, wz = w[0].tolist() if one else (w[:, 0], w[:, 1], w[:, 2])
    values, reachable, degenerate, flex = _wrist_terms(arm, wx, wy, wz, body, e_hi, m)
    if one:
        packed = np.array(values)[None]                                  # (1, TERMS.size)
        wrist_ok = bool(reachable and e_lo <= flex <= e_hi)
    else:
        packed = np.stack(values, -1)                                    # (W, TERMS.size)
        wrist_ok = reachable & (flex >= e_lo) & (flex <= e_hi)

    # per swivel sample
    step = float(st.swivel_step)
    gamma_prev = 0.0 if previous is None else previous.gamma
    p, angles, wrong_side = _sample_angles(packed, values[_SIN_EPS] < STRAIGHT, wrist_ok,
                                           degenerate, step, gamma_prev, one)

    # validity and ranking
    prev_angles = (0.0, 0.0, 0.0) if previous is None else (
        previous.alpha, previous.beta, previous.gamma)
    move = (previous, max_change, limits, smooth_bound, require, prev_angles)
    if one:
        valid, f_r, second, ranked = _rank_one(st, angles, wrong_side, body, flex, move)
        legal = None if smooth_bound else valid
        body, flex = packed[:, _AT_BODY], packed[:, _AT_FLEX]             # (1,) each
    else:
        legal, valid, f_r, second = _validate_many(st, angles, wrong_side, body, flex, move)
        ranked = None
    n_w = len(w)
    cos_phi, sin_phi = swivel_samples(step)
    # Solutions(...) would pass its 25 keywords through a dict (a class call hands
    # __init__ its keywords as one); the bound __init__ takes them as a function does
    out = Solutions.__new__(Solutions)
    out.__init__(wrists=w, body=body, sternum=packed[:, _AT_STERNUM],
                 shoulder=packed[:, _AT_SHOULDER],
                 elbow_coef=packed[:, _AT_ELBOW].reshape(n_w, 3, 3),
                 fore_coef=packed[:, _AT_FORE].reshape(n_w, 3, 3), cos_phi=cos_phi[0],
                 sin_phi=sin_phi[0], angles=angles, flex=flex, reachable=wrist_ok,
                 valid=valid, f_r=f_r, second=second, wrong_side=wrong_side,
                 hand_length=arm.hand_length, upper=p[:, 0:3], fore=p[:, 3:6],
                 turn=packed[:, _AT_TURN], eps=packed[:, _AT_EPS],
                 gamma_prev=float(gamma_prev), limits=limits, require_side=require,
                 legal=legal, ranked=ranked)
    return out


def _elbow_rules(arm: ArmModel, st, previous: ArmConfig | None, smooth_bound: bool):
    """(least and greatest elbow flexion, degrees; whether Algorithm 1's side is required)
    of a move from ``previous``: the settings' flexion limits, widened with
    ``smooth_bound`` to take in ``previous``'s own (as
    :func:`~reach_addon.core.limits.move_limits` widens the shoulder's), and the side
    required where ``Settings.elbow_side`` is "require", unless the move starts off it (a
    rig's own start pose may stay off it on the way back; the side then leads the ranking,
    :meth:`Solutions.order`)."""
    e_lo, e_hi = st.elbow_min, st.elbow_max
    if smooth_bound:
        e_lo, e_hi = min(e_lo, previous.elbow), max(e_hi, previous.elbow)
    require = st.elbow_side == "require"
    if require and smooth_bound and not on_elbow_side(arm, previous):
        require = False
    return e_lo, e_hi, require


def _body_rotation(arm: ArmModel, w: np.ndarray, st, body_rotation, one: bool):
    """The chest rotation (degrees) at each wrist of ``w`` (W, 3): ``body_rotation`` if
    given, else Table 1's (:func:`~reach_addon.core.torso.body_rotation_deg`). A float for
    ``one`` wrist, else an array (W,)."""
    if one:
        if body_rotation is None:
            return float(body_rotation_deg(w[0], arm.arm_length, arm.hand_length, st))
        if isinstance(body_rotation, float):
            return body_rotation
        return float(np.asarray(body_rotation, dtype=float).reshape(-1)[0])
    if body_rotation is None:
        return np.asarray(body_rotation_deg(w, arm.arm_length, arm.hand_length, st), dtype=float)
    return np.broadcast_to(np.asarray(body_rotation, dtype=float), (len(w),)).copy()


def _sample_angles(packed: np.ndarray, straight, wrist_ok, degenerate, step: float,
                   gamma_prev: float, one: bool):
    """Every swivel sample (every ``step`` degrees) of the wrists whose terms are the rows
    of ``packed`` (:data:`TERMS`). Returns (p, angles, wrong_side):

    * p (W, 9, S): the chest-frame u (3), f (3), Algorithm 1's side value (e - s)·n̂ and
      (u × f)_x, (u × f)_z, each affine in (cos φ, sin φ), so one matrix product with the
      swivel basis;
    * angles (W, 4, S): α, β, γ, θ (degrees); α, β, γ are NaN at a wrist that is not
      ``wrist_ok``, and γ is ``gamma_prev`` with a ``straight`` elbow (it shows no twist);
    * wrong_side (W, S): the elbow off Algorithm 1's side (never where the plane is
      ``degenerate``).

    (α, β) = θ (u_x, u_y) / |(u_x, u_y)| with θ = atan2(|u_xy|, -u_z). The twist
    γ = atan2(-f·t, f·r) (the module docstring) with both terms multiplied by 1 - u_z > 0
    and u·f = cos ε: atan2(u_x (cos ε - f_z) - (1 - u_z) f_x, u_x (u × f)_z + (1 - u_z)
    (u × f)_x), with no bend direction built."""
    n_w = len(packed)
    basis = swivel_basis(step)                                           # (3, S)
    n_s = basis.shape[1]
    p = packed[:, _AT_ROWS].reshape(n_w, 9, 3) @ basis
    ux, uy, uz, fx, fy, fz, side, cross_x, cross_z = p.transpose(1, 0, 2)
    angles = np.empty((n_w, 4, n_s))
    theta, gamma = angles[:, 3], angles[:, 2]                            # views, (W, S)
    h = np.hypot(ux, uy)
    np.degrees(np.arctan2(h, -uz), out=theta)
    np.multiply(p[:, 0:2], (theta / np.maximum(h, 1e-12))[:, None], out=angles[:, 0:2])
    down = 1.0 - uz
    cos_eps = packed[:, _AT_EPS][:, 0:1]
    np.degrees(np.arctan2(ux * (cos_eps - fz) - down * fx, ux * cross_z + down * cross_x),
               out=gamma)
    if one:
        if straight:
            gamma[:] = gamma_prev
        if not wrist_ok:
            angles[:, :3] = np.nan
        wrong_side = np.zeros((1, n_s), dtype=bool) if degenerate else side <= 0
    else:
        if straight.any():
            gamma[straight] = gamma_prev
        if not wrist_ok.all():
            angles[~wrist_ok, :3] = np.nan
        wrong_side = ~((side > 0) | degenerate[:, None])
    return p, angles, wrong_side


def _rank_one(st, angles: np.ndarray, wrong_side: np.ndarray, body: float, flex: float,
              move: tuple):
    """Validity and ranking of one wrist's samples (``angles`` (1, 4, S)). ``move``:
    (previous, max_change, limits, smooth_bound, require, prev_angles) of :func:`solve`.
    Returns (valid (1, S), f_R, second, ranked):

    * valid: inside ``limits`` and, with the smoothness bound, within ``max_change`` of
      ``previous`` (the two intersected into one interval per angle,
      :func:`~reach_addon.core.limits.valid_bounds`), on the elbow's side if required;
    * f_R and the second-level score of the valid samples (0 elsewhere): with at most
      :data:`_SCALAR_SCORING` of them, lists scored on floats (:func:`_score_floats`) and
      ``ranked`` = (``Settings.elbow_side``, their indices best first); else arrays
      (:func:`~reach_addon.core.strength.scores`) and ``ranked`` None."""
    previous, max_change, limits, smooth_bound, require, prev_angles = move
    n_s = angles.shape[2]
    bounds = valid_bounds(limits, previous, body, flex, max_change) if smooth_bound \
        else limits
    if bounds is None:                       # the body or the elbow moves too far
        valid = np.zeros((1, n_s), dtype=bool)
    else:
        valid = np.logical_and.reduce((angles >= bounds[0]) & (angles <= bounds[1]), 1)
        if len(bounds) == 3:                 # a twist window that wraps round ±180°
            valid &= smooth_angles(previous, body, angles, flex, max_change, SCALAR)
        if require:
            valid &= ~wrong_side
    ks = valid[0].nonzero()[0]
    if len(ks) > _SCALAR_SCORING:
        f_r, second = strength.scores(angles[:, 0], angles[:, 1], angles[:, 2], prev_angles, st)
        return valid, f_r, second, None
    ks = ks.tolist()
    f_r, second = _score_floats(ks, angles, prev_angles, st)
    wrong = wrong_side[0].tolist() if st.elbow_side == "prefer" or \
        (st.elbow_side == "require" and not require) else None
    return valid, f_r, second, (st.elbow_side, _rank(ks, f_r, second, wrong))


def _score_floats(ks: list, angles: np.ndarray, prev_angles: tuple, st):
    """(f_R, second-level score), lists over one wrist's S samples (``angles`` (1, 4, S)),
    of the samples ``ks`` (0 elsewhere), scored on floats
    (:func:`~reach_addon.core.strength.score_float`: a numpy call costs ~1 µs each)."""
    n_s = angles.shape[2]
    f_r, second = [0] * n_s, [0.0] * n_s
    if not ks:
        return f_r, second
    a_, b_, g_, _t = angles[0].tolist()
    a0, b0, g0 = prev_angles
    lh, lv = st.preferred_level_h, st.preferred_level_v
    wa, wb, wg = st.weight_alpha, st.weight_beta, st.weight_gamma
    score = strength.score_float
    if st.strength_reading == "split":
        for k in ks:
            f_r[k], second[k] = score(a_[k], b_[k], g_[k], a0, b0, g0, lh, lv, wa, wb, wg)
    else:
        read = strength.strength_angles
        for k in ks:
            sa, sb = read(a_[k], b_[k], st.strength_reading)
            f_r[k], second[k] = score(a_[k], b_[k], g_[k], a0, b0, g0, lh, lv, wa, wb, wg,
                                      sa, sb)
    return f_r, second


def _validate_many(st, angles: np.ndarray, wrong_side: np.ndarray, body, flex, move: tuple):
    """Validity of many wrists' samples (``angles`` (W, 4, S); ``move`` as for
    :func:`_rank_one`): (legal, valid, f_R, second), each (W, S). Legal: inside ``limits``,
    on the elbow's side if required; valid: legal and, with the smoothness bound, within
    ``max_change`` of ``previous`` (:func:`~reach_addon.core.limits.smooth_angles`); f_R
    and the second-level score of the valid samples (0 elsewhere)."""
    previous, max_change, limits, smooth_bound, require, prev_angles = move
    legal = np.logical_and.reduce((angles >= limits[0]) & (angles <= limits[1]), 1)
    if require:
        legal &= ~wrong_side
    valid = legal
    if smooth_bound:
        valid = legal & smooth_angles(previous, body, angles, flex, max_change, ARRAY)
    if valid.any():
        f_r, second = strength.scores(angles[:, 0], angles[:, 1], angles[:, 2], prev_angles, st)
    else:
        f_r, second = np.zeros(valid.shape, dtype=np.int8), np.zeros(valid.shape)
    return legal, valid, f_r, second


@lru_cache(maxsize=64)
def _min_reach(l1: float, l2: float, elbow_max: float) -> float:
    """:meth:`ArmModel.min_reach`, remembered (it is asked for every wrist position)."""
    interior = math.radians(180.0 - elbow_max)
    return math.sqrt(max(l1 * l1 + l2 * l2 - 2 * l1 * l2 * math.cos(interior), 0.0))


class WristTerms(NamedTuple):
    """Where each quantity of :func:`_wrist_terms` sits in its flat row of numbers (one row
    per wrist: the rows are stacked into one array, and these slices read it)."""

    sternum: slice          # (3,)
    shoulder: slice         # (3,)
    elbow_coef: slice       # (3 × 3,): the elbow's centre, r·b1, r·b2
    fore_coef: slice        # (3 × 3,): the unit forearm direction's coefficients
    rows: slice             # (9 × 3,): chest-frame rows of u (3), f (3), the side value and
    #                         (u × f)_x, (u × f)_z, each multiplying (1, cos φ, sin φ)
    eps: slice              # (cos ε, sin ε)
    turn: slice             # (cos, sin) of the chest turn
    body: int               # the chest rotation
    flex: int               # the elbow flexion
    size: int


def _term_layout(**sizes) -> WristTerms:
    fields, start = {}, 0
    for name, size in sizes.items():
        fields[name] = start if size == 0 else slice(start, start + size)
        start += max(size, 1)
    return WristTerms(**fields, size=start)


#: The layout of :func:`_wrist_terms`' values (0: a single number).
TERMS = _term_layout(sternum=3, shoulder=3, elbow_coef=9, fore_coef=9, rows=27, eps=2, turn=2,
                     body=0, flex=0)
_SIN_EPS = TERMS.eps.start + 1
_AT_STERNUM, _AT_SHOULDER, _AT_ELBOW, _AT_FORE, _AT_ROWS, _AT_EPS, _AT_TURN, _AT_BODY, _AT_FLEX, \
    _TERMS_SIZE = TERMS


def _wrist_terms(arm: ArmModel, wx, wy, wz, body, elbow_max: float, m):
    """Everything about one wrist position that does not depend on the swivel angle,
    written once for floats (``m`` = SCALAR) and for arrays of wrists (``m`` = ARRAY).

    Returns (values, reachable, degenerate, flexion), ``values`` being the numbers laid out
    by :data:`TERMS` (:class:`WristTerms`): sternum, shoulder, elbow coefficients,
    forearm direction coefficients, the chest-frame coefficient rows of u, f, Algorithm
    1's side value and the x and z components of u × f; then cos ε, sin ε, the cos and
    sin of the chest turn, the chest rotation and the elbow flexion."""
    l1, l2 = arm.upper_arm_length, arm.forearm_length
    rad = m.radians(body)
    cb, sb = m.cos(rad), m.sin(rad)
    s0x, s0y, s0z = arm.shoulder.tolist()
    sx, sy, sz = cb * s0x + sb * s0y, cb * s0y - sb * s0x, s0z + 0.0 * cb
    t0x, t0y, t0z = arm.sternum.tolist()
    dx, dy, dz = wx - sx, wy - sy, wz - sz
    d = m.sqrt(dx * dx + dy * dy + dz * dz)
    tol = 1e-9 * arm.arm_length
    reachable = (d <= l1 + l2 + tol) & (d >= _min_reach(l1, l2, elbow_max) - tol) & (d > tol)
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
    rb1 = (r * b1x, r * b1y, r * b1z)
    rb2 = (r * b2x, r * b2y, r * b2z)
    cos_eps = m.clip((d * d - l1 * l1 - l2 * l2) / (2 * l1 * l2), -1.0, 1.0)   # u·f = cos ε
    # Algorithm 1: side = (e - s)·n̂, affine in (cos φ, sin φ) like e.
    kx, ky, kz, degenerate = side_normal((wx, wy, wz), (sx, sy, sz), arm.waist.tolist(), m)
    zero = 0.0 * cb
    # Unit upper arm and forearm directions, canonical frame, as (1, cos φ, sin φ) rows...
    upper = ((cx - sx) / l1, (cy - sy) / l1, (cz - sz) / l1,
             rb1[0] / l1, rb1[1] / l1, rb1[2] / l1, rb2[0] / l1, rb2[1] / l1, rb2[2] / l1)
    fore = ((wx - cx) / l2, (wy - cy) / l2, (wz - cz) / l2,
            -rb1[0] / l2, -rb1[1] / l2, -rb1[2] / l2, -rb2[0] / l2, -rb2[1] / l2,
            -rb2[2] / l2)

    def chest(c):
        # ... turned into the chest frame (x' = c x - s y, y' = s x + c y) and laid out
        # one row per component: (x'_0, x'_1, x'_2), (y'_0, ...), (z'_0, ...).
        return (cb * c[0] - sb * c[1], cb * c[3] - sb * c[4], cb * c[6] - sb * c[7],
                sb * c[0] + cb * c[1], sb * c[3] + cb * c[4], sb * c[6] + cb * c[7],
                c[2], c[5], c[8])

    # u × f = (e - s) × (w - s) / (L1 L2) = (d r / (L1 L2)) (sin φ b1 - cos φ b2): linear in
    # (cos φ, sin φ); its chest-frame x and z rows give the twist without a division.
    q = d * r / (l1 * l2)
    cross_x, cross_y, cross_z = (zero, -q * b2x, q * b1x), (zero, -q * b2y, q * b1y), \
        (zero, -q * b2z, q * b1z)
    flex = m.degrees(m.acos(cos_eps))
    values = (cb * t0x + sb * t0y, cb * t0y - sb * t0x, t0z + zero, sx, sy, sz,
              cx, cy, cz) + rb1 + rb2 + fore + chest(upper) + chest(fore) + (
        (cx - sx) * kx + (cy - sy) * ky + (cz - sz) * kz,
        rb1[0] * kx + rb1[1] * ky + rb1[2] * kz,
        rb2[0] * kx + rb2[1] * ky + rb2[2] * kz) + tuple(
        cb * cross_x[j] - sb * cross_y[j] for j in range(3)) + cross_z
    values += (cos_eps, m.sqrt(1.0 - cos_eps * cos_eps), cb, sb, body + zero, flex)
    return values, reachable, degenerate, flex


