"""The swivel and the hand chosen together along a whole path, the elbow kept low.

The search (:mod:`~reach_addon.core.search`) and the shortcut (:mod:`~reach_addon.core.motion`)
pick each position's swivel greedily: the strongest candidate (the paper's f_R, then the
second-level score) within the smoothness bound of the one before. Where a path goes down
past an edge, that choice can lift the elbow over a hand that is below the shoulder, a
"chicken wing", and, bounded at every step, cannot bring it back down before the hand has
gone on. People reaching below the shoulder keep the elbow below it (the paper is silent
here; this is Reach's own choice).

:func:`relax_elbow` chooses the swivel and the hand of every position of such a path again,
all together, by dynamic programming over (swivel sample, hand sample) states (the wrist
positions and chest rotations kept, the path's two ends kept as they are):

    cost = Σ_i [ WING_COST · wing_i + elbow_comfort · lift_i + f_R,i
                 + wrist_relax_weight · (bend_i / 45°)² ]
         + Σ_i SWING_COST · (swivel samples turned between i - 1 and i)²

- ``wing_i`` (:func:`chicken_wing`): 1 where the elbow is more than ``wing_margin`` arm
  lengths above the shoulder while the wrist is more than that below it;
- ``lift_i`` (:func:`elbow_lift`): how far the elbow is above the shoulder, in arm lengths,
  while the wrist is below it (``Settings.elbow_comfort`` of 10 makes a lift of 0.1 arm
  lengths cost as much as one level of f_R);
- f_R: the paper's strength category of the swivel candidate (0 best);
- bend: the hand's turn from the rig's rest alignment (``ArmModel.rest_coefficients``), as
  the hand pass costs it (:mod:`~reach_addon.core.hand_dp`);
- the last term prefers the swivel that turns least between neighbours.

Hard constraints are the search's own: every swivel legal and its arm clear of the
obstacles and the body (:meth:`~reach_addon.core.generator.ConfigurationGenerator.clear_swivels`),
every hand clear (:meth:`~reach_addon.core.generator.ConfigurationGenerator.hands_clear`),
every transition within the smoothness bound (:func:`~reach_addon.core.limits.smooth`) and
every hand within ``hand_step_turn`` of the last
(:meth:`~reach_addon.core.generator.ConfigurationGenerator.hand_order`). The path is then
rebuilt through :meth:`~reach_addon.core.generator.ConfigurationGenerator.solve` with each
chosen swivel and hand, which also checks the hand's sweep and the arm's swing, and each
step is checked as two keys interpolate
(:meth:`~reach_addon.core.generator.ConfigurationGenerator.transition_problem`, at half the
clearance: on GoMakeHuman's shelf the elbow kept low put the hand against the shelf's
inner side between keys, and the whole path fell back to the search's wings); a state
refused is banned and the DP runs again (at most :data:`MAX_ROUNDS` times); where the
refusal is between keys, so is the elbow's swing into it from the last position's swivel,
and every swing from there farther the same way round (on GoMakeHuman's chase the DP
otherwise spent its rounds on the neighbours of one 35° swing that swept the hand through
the obstacle). The hand turns at most ``hand_step_turn`` relative to the forearm between
neighbours even where they are more than a step apart. Over a chase's frames, which the
hand pass cannot slow, the hand's whole turn in space (the arm's swing included) costs
:data:`OVER_TURN_COST`, and as much again per bound's worth, beyond
``hand_space_turn_speed`` a frame, so that a lowered elbow does not come at a hand the pass
must then turn too fast. The new path is
kept only if it has fewer wing positions than the old, and the motion's every-instant checks
judge it as they judge any path (the planner keeps the old one where they do not pass).

The pass runs only on a path with a wing: elsewhere the search's strongest-first choice
stands, as the paper has it. A chase's frames go through it too (:mod:`.chase`, each frame
with its own obstacles), kept where the hand pass over them fares no worse.
"""

from __future__ import annotations

import numpy as np

from .arm import (ArmConfig, Pose, frame_angle, hand_coefficients, hand_orientation,
                  rolled_hand_frame)
from .hand_grid import wrist_turn
from .limits import smooth

#: Cost of one position with a chicken wing: many times what a position's other terms add
#: up to (f_R ≤ 2, the lift ≤ ``elbow_comfort`` × ~0.5, the hand's bend ≤
#: ``wrist_relax_weight`` × ~4 at the default weights), so the DP keeps a wing only where
#: avoiding it would cost comfort over many positions, or where no clear path avoids it.
WING_COST = 100.0
#: Cost of turning the swivel by one sample between neighbouring positions (squared).
SWING_COST = 0.05
#: Cost of a hand turning in space beyond its bound between two of a chase's frames
#: (which the hand pass cannot slow), and again per bound's worth beyond: at least a wing,
#: so the DP lowers an elbow by turning the hand too fast only where nothing else would.
OVER_TURN_COST = WING_COST
#: Rounds of the DP after the rebuild refused a choice.
MAX_ROUNDS = 12


def chicken_wing(shoulder_z, elbow_z, wrist_z, length: float, margin: float):
    """Wing: e_z - s_z > m·L and s_z - w_z > m·L (canonical z up, m = ``margin``)."""
    return ((np.asarray(elbow_z) - shoulder_z > margin * length)
            & (shoulder_z - np.asarray(wrist_z) > margin * length))


def elbow_lift(shoulder_z, elbow_z, wrist_z, length: float):
    """Lift: max(0, e_z - s_z) / L where w_z < s_z, else 0 (arm lengths)."""
    lift = np.maximum(0.0, np.asarray(elbow_z) - shoulder_z) / length
    return np.where(np.asarray(wrist_z) < shoulder_z, lift, 0.0)


def wing_count(poses, length: float, margin: float) -> int:
    """How many of ``poses`` are chicken wings (:func:`chicken_wing`)."""
    j = np.array([p.joints for p in poses])
    return int(chicken_wing(j[:, 1, 2], j[:, 2, 2], j[:, 3, 2], length, margin).sum())


def _swing_steps(a: np.ndarray, b: np.ndarray, count: int) -> np.ndarray:
    """Swivel samples between the samples ``a`` (m,) and ``b`` (n,), round the circle."""
    d = np.abs(a[:, None] - b[None, :])
    return np.minimum(d, count - d)


class _Layer:
    """One position's states: swivel samples (their configurations, joints, bend directions,
    node costs) × hand samples (which are clear)."""

    def __init__(self, ks, angles, body: float, flex: float, cost, clear, joints, bends):
        self.ks = np.asarray(ks, dtype=int)
        self.angles = np.asarray(angles, dtype=float).reshape(-1, 3)   # α, β, γ
        self.body, self.flex = float(body), float(flex)
        self.cost = np.asarray(cost, dtype=float)                      # (swivels, hands)
        self.clear = np.asarray(clear, dtype=bool)                     # (swivels, hands)
        self.joints, self.bends = joints, bends
        self.frames = None      # (swivels, hands, 3, 3): the hand's frame in space (d, g, d × g)


def relax_elbow(generators, poses: list, space_turn: float | None = None) -> list:
    """``poses`` (a smoothed, validated path, start first, or a chase's frames) with the
    swivels and hands chosen again as the module docstring says, or ``poses`` itself where
    it has no chicken wing, where ``Settings.elbow_comfort`` is 0 or where no path with
    fewer wings is found. ``generators``: one
    :class:`~reach_addon.core.generator.ConfigurationGenerator` for every pose (a chase
    against moving obstacles has one per frame), or one for all. ``space_turn`` (degrees,
    or None): the most the hand may turn in space from one pose to the next (a chase's
    frames, which the hand pass cannot slow)."""
    gens = list(generators) if isinstance(generators, (list, tuple)) else \
        [generators] * len(poses)
    st, arm = gens[0].settings, gens[0].arm
    length, margin = arm.arm_length, st.wing_margin
    if st.elbow_comfort <= 0.0 or len(poses) < 3 or wing_count(poses, length, margin) == 0:
        return poses
    hands = list(gens[0].hand_samples)
    coef = np.array([hand_coefficients(*h) for h in hands])
    bend = wrist_turn(coef, np.asarray(arm.rest_coefficients, dtype=float))
    hand_cost = st.wrist_relax_weight * (bend / 45.0) ** 2
    layers = [None] + [_layer(g, p, coef, hand_cost, length, margin)
                       for g, p in zip(gens[1:-1], poses[1:-1])]
    banned: set = set()
    for _round in range(MAX_ROUNDS):
        path = _dp(gens, poses, layers, hands, coef, banned, space_turn)
        if path is None:
            return poses
        out, refused = _rebuild(gens, poses, layers, hands, path)
        if refused is None:
            return out if wing_count(out, length, margin) < wing_count(poses, length, margin) \
                else poses
        banned.update(refused)
    return poses


def _layer(generator, pose: Pose, coef, hand_cost, length: float, margin: float) -> _Layer:
    """The states at ``pose``'s wrist position and chest rotation."""
    st = generator.settings
    body = pose.config.body_rotation
    sol, ks, joints = generator.clear_swivels(pose.wrist, body, pose)
    if not ks:
        empty = np.zeros((0, len(coef)))
        return _Layer([], np.zeros((0, 3)), body, pose.config.elbow, empty, empty, joints, [])
    s, e, w = joints[:, 1, 2], joints[:, 2, 2], joints[:, 3, 2]
    swivel_cost = (WING_COST * chicken_wing(s, e, w, length, margin)
                   + st.elbow_comfort * elbow_lift(s, e, w, length) + sol.f_r[0, ks])
    bends = [sol.bend_at(0, k) for k in ks]
    # every hand of every swivel in one query: the wrist, hence the obstacles near it, is
    # the same for all (:meth:`hands_clear` per swivel, at once)
    axes = np.array([generator.hand_axes(joints[m], bends[m]) for m in range(len(ks))])
    tips = joints[0, 3] + generator.arm.hand_length * np.einsum("hc,mcx->mhx", coef, axes)
    clear = generator.tips_clear(joints[0], body, tips.reshape(-1, 3),
                                 hinge=np.repeat(axes[:, 2], len(coef), 0)).reshape(len(ks), -1)
    layer = _Layer(ks, sol.angles[0][:3, ks].T, sol.body[0], sol.flex[0],
                   swivel_cost[:, None] + hand_cost[None, :], clear, joints, bends)
    d = tips - joints[0, 3]
    hinge = np.cross(joints[:, 2] - joints[:, 1], np.asarray(bends))              # (m, 3)
    layer.frames = hand_orientation(d / np.linalg.norm(d, axis=-1, keepdims=True),
                                    np.repeat(hinge[:, None], len(coef), 1))     # (m, h, 3, 3)
    return layer


def _smooth_from(config: ArmConfig, layer: _Layer, bound: float) -> np.ndarray:
    """Which of ``layer``'s swivels are within the smoothness bound of ``config``."""
    a = layer.angles
    return smooth(config, layer.body, a[:, 0], a[:, 1], a[:, 2], layer.flex, bound)


def _hands_after(generator, hand, scale: float, hands: list) -> np.ndarray:
    """Which of ``hands`` may follow ``hand`` (:meth:`hand_order`)."""
    within = set(generator.hand_order(tuple(hand), scale))
    return np.array([h in within for h in hands])


def _dp(gens, poses, layers, hands, coef, banned, space=None):
    """The least-cost (swivel index, hand index) per middle position, or None where no
    choice passes the bounds. A step moves the arm with the hand as it was (so that hand
    must be clear at the new pose too), then turns the hand within its bound, as
    :meth:`~reach_addon.core.generator.ConfigurationGenerator.solve` places it. ``space``
    (degrees, or None): the most the hand's frame may turn in space from one position to
    the next, the arm's swing included (a chase's frames, which cannot be slowed)."""
    n, generator = len(poses), gens[0]      # (bounds and hand orders: the settings')
    count = int(round(360.0 / generator.settings.swivel_step))
    first = layers[1]
    if not len(first.ks):
        return None
    start = poses[0]
    ok = _smooth_from(start.config, first, generator.max_change(start, poses[1].wrist))
    own = np.array([bool(gens[1].hands_clear(first.joints[m], first.bends[m], first.body,
                                               [hand_coefficients(*start.hand)])[0])
                    for m in range(len(first.ks))])
    into = _hands_after(generator, start.hand, 1.0, hands)
    ok = (ok & own)[:, None] & into[None, :] & first.clear
    if space is not None:
        turn = frame_angle(rolled_hand_frame(start)[None, None], first.frames)
        cost = first.cost + _over(turn, space)
    else:
        cost = first.cost
    total = _ban(np.where(ok, cost, np.inf), 1, first, hands, banned)
    back = [None, None]
    adj = np.array([_hands_after(generator, h, 1.0, hands) for h in hands])        # (h, h')
    for i in range(2, n - 1):
        prev, cur = layers[i - 1], layers[i]
        if not len(cur.ks):
            return None
        bound = generator.max_change(poses[i - 1], poses[i].wrist)
        ok = np.array([_smooth_from(ArmConfig(prev.body, *prev.angles[j].tolist(), prev.flex),
                                    cur, bound) for j in range(len(prev.ks))])   # (j, m)
        ok &= ~_banned_swings(i, prev, cur, count, banned)
        swing = SWING_COST * _swing_steps(prev.ks, cur.ks, count) ** 2           # (j, m)
        step = _step if space is None else _step_in_space
        t, pointers = step(total, ok, swing, cur, adj, prev, space)
        total = _ban(np.where(cur.clear, t + cur.cost, np.inf), i, cur, hands, banned)
        back.append(pointers)
    last, goal = layers[n - 2], poses[n - 1]
    gc = goal.config
    at_goal = _Layer([0], [[gc.alpha, gc.beta, gc.gamma]], gc.body_rotation, gc.elbow,
                     [[0.0]], [[True]], None, None)
    bound = generator.max_change(poses[n - 2], goal.wrist)
    ok = np.array([_smooth_from(ArmConfig(last.body, *a.tolist(), last.flex), at_goal,
                                bound)[0] for a in last.angles])
    scale = generator.move_scale(poses[n - 2], goal.wrist)
    turn = np.array([tuple(goal.hand) in set(generator.hand_order(h, scale)) for h in hands])
    held = gens[-1].hands_clear(goal.joints, goal.bend, gc.body_rotation, coef)
    ok = ok[:, None] & (turn & held)[None, :]
    if space is not None:
        turn = frame_angle(last.frames, rolled_hand_frame(goal)[None, None])
        total = total + _over(turn, space)
    total = np.where(ok, total, np.inf)
    if not np.isfinite(total).any():
        return None
    m, h = (int(v) for v in np.unravel_index(int(np.argmin(total)), total.shape))
    path = [(m, h)]
    for i in range(n - 2, 1, -1):
        bj, bh = back[i]
        m, h = int(bj[m, h]), int(bh[m, h])
        path.append((m, h))
    return [None] + path[::-1]


def _step(total, ok, swing, cur: _Layer, adj, _prev, _space):
    """One position of the DP: the arm moves with the hand h, (j, h) → (m, h), h clear at
    m; then the hand turns h → h' there. Returns the cost of each (m, h') before ``cur``'s
    own, and the (j, h) it came from."""
    u = np.where(ok[:, :, None], total[:, None, :] + swing[:, :, None], np.inf)  # (j, m, h)
    bj = np.argmin(u, axis=0)                                                 # (m, h)
    u = np.where(cur.clear, np.take_along_axis(u, bj[None], 0)[0], np.inf)    # (m, h)
    t = np.where(adj[None], u[:, :, None], np.inf)                           # (m, h, h')
    bh = np.argmin(t, axis=1)                                                 # (m, h')
    t = np.take_along_axis(t, bh[:, None, :], 1)[:, 0]
    return t, (np.take_along_axis(bj, bh, 1), bh)


def _step_in_space(total, ok, swing, cur: _Layer, adj, prev: _Layer, space: float):
    """:func:`_step` with the hand's whole turn in space from (j, h) to (m, h') at most
    ``space`` degrees: every (j, h, m, h') at once."""
    feasible = ok[:, None, :, None] & cur.clear.T[None, :, :, None] & adj[None, :, None, :]
    over = _over(frame_angle(prev.frames[:, :, None, None], cur.frames[None, None]), space)
    u = np.where(feasible, total[:, :, None, None] + swing[:, None, :, None] + over, np.inf)
    j, h, m, h2 = u.shape
    flat = u.reshape(j * h, m, h2)
    best = np.argmin(flat, axis=0)                                            # (m, h')
    t = np.take_along_axis(flat, best[None], 0)[0]
    return t, (best // h, best % h)


def _over(turn, space: float) -> np.ndarray:
    """Cost of a hand turning ``turn`` degrees in space where ``space`` is its bound:
    OVER_TURN_COST for going beyond it and as much again per bound's worth beyond it,
    nothing within it."""
    over = np.maximum(0.0, np.asarray(turn) - space) / space
    return OVER_TURN_COST * np.where(over > 1e-9, 1.0 + over, 0.0)


def _banned_swings(i: int, prev: _Layer, cur: _Layer, count: int, banned) -> np.ndarray:
    """(j, m): is the swing from ``prev``'s swivel j to ``cur``'s swivel m banned — a swing
    from the same swivel the same way round at least as far as one the rebuild refused
    between keys (``("swing", i, k, turn)`` in ``banned``)?"""
    out = np.zeros((len(prev.ks), len(cur.ks)), dtype=bool)
    for j, k in enumerate(prev.ks.tolist()):
        for _tag, at, k0, turn in (b for b in banned if b[0] == "swing"):
            if at == i and k0 == k:
                d = (cur.ks - k + count // 2) % count - count // 2     # signed, round the circle
                out[j] |= (d * turn > 0) & (np.abs(d) >= abs(turn))
    return out


def _ban(total, i: int, layer: _Layer, hands, banned) -> np.ndarray:
    for m, k in enumerate(layer.ks.tolist()):
        for h, hand in enumerate(hands):
            if (i, k, hand) in banned:
                total[m, h] = np.inf
    return total


def _rebuild(gens, poses, layers, hands, path):
    """The poses of the DP's ``path`` through the generator (the hand's sweep and the arm's
    swing checked): (poses, None), or (None, (position, swivel sample, hand)) of the first
    state refused."""
    out = [poses[0]]
    for i in range(1, len(poses) - 1):
        m, h = path[i]
        k, p = int(layers[i].ks[m]), poses[i]
        pose = gens[i].solve(p.wrist, out[-1], body_rotation=p.config.body_rotation,
                             hand_scale=1.0, swivel=k, hand_sample=hands[h])
        if pose is None:
            return None, [(i, k, hands[h])]
        if gens[i].transition_problem(out[-1], pose) is not None:
            # refused between keys: the state, and where it swings the elbow from the
            # last position's swivel, that swing and any farther the same way
            refused = [(i, k, hands[h])]
            if i > 1:
                k0 = int(layers[i - 1].ks[path[i - 1][0]])
                count = int(round(360.0 / gens[i].settings.swivel_step))
                turn = (k - k0 + count // 2) % count - count // 2
                if turn:
                    refused.append(("swing", i, k0, turn))
            return None, refused
        out.append(pose)
    if not gens[-1].smooth_between(out[-1], poses[-1]):
        m, h = path[-1]
        return None, [(len(poses) - 2, int(layers[-2].ks[m]), hands[h])]
    out.append(poses[-1])
    return out, None
