"""The sternum-rooted arm: its geometry, the shoulder angle convention and forward kinematics.

The core works in the **canonical arm frame**: origin on the vertical axis through the
spine at chest height, x toward the reaching arm's side, y forward, z up (a left arm's
frame is the body frame mirrored in x, so one set of formulas serves both arms).
:attr:`ArmModel.to_world` maps canonical points to world space, where the obstacles are.
Lengths are in the figure's units.

A configuration (:class:`ArmConfig`) is five angles in degrees: the body (chest) rotation
about the spine axis, the shoulder angles α, β, γ and the elbow flexion. With ``u`` the
upper arm's direction in the chest frame, θ = acos(-u_z) its elevation from hanging and
φ = atan2(u_y, u_x) the direction it is raised toward, α = θ cos φ (abduction +) and
β = θ sin φ (flexion +) (:func:`shoulder_angles`); the humeral twist γ (internal rotation
+) is the angle about -u from :func:`swing_reference` to the direction the forearm bends
toward (:func:`twist_angle`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from .errors import ReachError, require_finite
from .numeric import cross
from .torso import rotate_about_spine, spine_rotation_matrix

#: Joint order of :attr:`Pose.joints`.
JOINTS = ("sternum", "shoulder", "elbow", "wrist", "hand")


@dataclass(frozen=True)
class Capsule:
    """A body part the arm may not pass through: the segment ``a``-``b`` (canonical frame)
    swept by ``radius``. ``turns_with_chest`` capsules (chest, head) follow the chest
    rotation; the others (abdomen, pelvis) stay."""

    name: str
    a: np.ndarray
    b: np.ndarray
    radius: float
    turns_with_chest: bool = True

    def __post_init__(self):
        object.__setattr__(self, "a", require_finite(f"body capsule '{self.name}'", self.a))
        object.__setattr__(self, "b", require_finite(f"body capsule '{self.name}'", self.b))
        if not self.radius > 0:
            raise ReachError(f"body capsule '{self.name}' has radius {self.radius}; it must be > 0")


@dataclass(frozen=True)
class ArmModel:
    """Geometry of one arm and the body it hangs on, in the canonical arm frame.

    Lengths and radii are in the figure's own units (whatever the rig uses); the planner's
    settings are in arm lengths (:attr:`arm_length` = upper arm + forearm, shoulder to
    wrist, the wrist being the end-effector).

    ``sternum`` is the IK root, ``shoulder`` the glenohumeral centre at rest (chest
    rotation 0), ``waist`` the point Algorithm 1 uses for the body plane. ``to_world`` is a
    4×4 rigid transform (a reflection allowed, no scale) from canonical to world space.
    """

    sternum: np.ndarray
    shoulder: np.ndarray
    waist: np.ndarray
    upper_arm_length: float
    forearm_length: float
    hand_length: float
    upper_arm_radius: float
    forearm_radius: float
    hand_radius: float
    to_world: np.ndarray = field(default_factory=lambda: np.eye(4))
    body_capsules: tuple = ()
    side: str = "right"
    name: str = "arm"
    #: metres per figure unit (Blender's unit scale), for messages in centimetres
    metres_per_unit: float = 1.0
    #: The wrist's two angles (degrees, :func:`hand_direction`) at which the rig's rest pose
    #: holds the hand on the forearm: its neutral wrist, which the hand pass relaxes toward
    #: and the plan's bend figures are measured from (arccos of the coefficients' dot,
    #: :func:`~reach_addon.core.hand_grid.wrist_turn`). (0, 0): the
    #: forearm's line. (The search still tries the hand nearest the forearm's line first:
    #: that order decides which clear hand the path carries; the hand pass then chooses
    #: the hand keyed.)
    hand_rest: tuple = (0.0, 0.0)
    #: The hand as skinned (:mod:`.hand_shape`): capsules ((a, b, r), …) in the hand's frame
    #: (d, g, d × g), the wrist at the origin, canonical units, that the collision checker
    #: tests in place of the axis capsule (wrist → far end, ``hand_radius``). Empty: that
    #: capsule (a hand without skin, or an arm built by hand).
    hand_shape: tuple = ()

    def __post_init__(self):
        label = f"arm '{self.name}'"
        for key in ("sternum", "shoulder", "waist"):
            value = require_finite(f"{label} {key}", getattr(self, key))
            if value.shape != (3,):
                raise ReachError(f"{label} {key} must be a 3-vector, got shape {value.shape}")
            object.__setattr__(self, key, value)
        for key in ("upper_arm_length", "forearm_length", "hand_length", "upper_arm_radius",
                    "forearm_radius", "hand_radius"):
            value = float(require_finite(f"{label} {key.replace('_', ' ')}", getattr(self, key)))
            if key in ("upper_arm_length", "forearm_length") and not value > 1e-9:
                raise ReachError(
                    f"{label}: the {key.replace('_', ' ')} is {value:g}, a zero-length "
                    "segment; check the bone map (upper arm, forearm and hand must be "
                    "different bones with length)")
            if value < 0:
                raise ReachError(f"{label} {key.replace('_', ' ')} is negative ({value:g})")
            object.__setattr__(self, key, value)
        m = require_finite(f"{label} transform", self.to_world)
        if m.shape != (4, 4):
            raise ReachError(f"{label} transform must be 4×4")
        linear = m[:3, :3]
        if not np.allclose(linear @ linear.T, np.eye(3), atol=1e-6):
            raise ReachError(
                f"{label}: the body frame is not rigid (scaled or sheared); "
                "apply scale is not needed, but the frame passed to the core must be orthonormal")
        object.__setattr__(self, "to_world", m)
        object.__setattr__(self, "_from_world", np.linalg.inv(m))
        rest = tuple(float(v) for v in require_finite(f"{label} hand rest", self.hand_rest))
        if len(rest) != 2:
            raise ReachError(f"{label} hand rest must be two angles, got {len(rest)}")
        object.__setattr__(self, "hand_rest", rest)
        shape = []
        for a, b, r in self.hand_shape:
            a, b = (require_finite(f"{label} hand shape", v) for v in (a, b))
            r = float(require_finite(f"{label} hand shape radius", r))
            if a.shape != (3,) or b.shape != (3,) or r < 0.0:
                raise ReachError(f"{label} hand shape: each capsule is two 3-vectors and a "
                                 "radius of 0 or more")
            shape.append((tuple(a.tolist()), tuple(b.tolist()), r))
        object.__setattr__(self, "hand_shape", tuple(shape))
        object.__setattr__(self, "rest_coefficients", hand_coefficients(*rest))
        if self.side not in ("right", "left"):
            raise ReachError(f"{label}: side must be 'right' or 'left', got {self.side!r}")
        if np.linalg.norm(self.shoulder - self.sternum) < 1e-9:
            raise ReachError(f"{label}: shoulder and sternum coincide; check the bone map")
        caps = tuple(self.body_capsules)
        object.__setattr__(self, "body_capsules", caps)
        # the capsules on floats, with each one's centre and half length, for the body
        # test of every pose tried (body_capsules.body_capsules_at)
        floats = []
        for c in caps:
            p, q = [float(v) for v in c.a], [float(v) for v in c.b]
            floats.append((p, q, [0.5 * (p[i] + q[i]) for i in range(3)],
                           0.5 * math.dist(p, q), float(c.radius), bool(c.turns_with_chest)))
        object.__setattr__(self, "capsule_floats", tuple(floats))
        # per configuration, is the elbow on Algorithm 1's side (limits.on_elbow_side)
        object.__setattr__(self, "side_cache", {})

    @property
    def arm_length(self) -> float:
        """Upper arm + forearm: the unit of every length setting, and the farthest the
        wrist gets from the shoulder (a straight arm)."""
        return self.upper_arm_length + self.forearm_length

    def min_reach(self, elbow_max_deg: float) -> float:
        """Nearest wrist distance from the shoulder at the elbow flexion limit (law of
        cosines with interior angle 180° - flexion)."""
        l1, l2 = self.upper_arm_length, self.forearm_length
        interior = np.radians(180.0 - elbow_max_deg)
        return float(np.sqrt(max(l1 * l1 + l2 * l2 - 2 * l1 * l2 * np.cos(interior), 0.0)))

    def to_world_points(self, points):
        """Canonical points (..., 3) to world space."""
        p = np.asarray(points, dtype=float)
        return p @ self.to_world[:3, :3].T + self.to_world[:3, 3]

    def to_world_vectors(self, vectors):
        """Canonical directions (..., 3) to world space (no translation)."""
        return np.asarray(vectors, dtype=float) @ self.to_world[:3, :3].T

    def to_canonical_points(self, points):
        """World points (..., 3) to the canonical arm frame."""
        inv = self._from_world
        p = np.asarray(points, dtype=float)
        return p @ inv[:3, :3].T + inv[:3, 3]


@dataclass(frozen=True)
class ArmConfig:
    """The five angles of one arm posture, in degrees."""

    body_rotation: float
    alpha: float
    beta: float
    gamma: float
    elbow: float

    def as_array(self) -> np.ndarray:
        return np.array([self.body_rotation, self.alpha, self.beta, self.gamma, self.elbow])

    @classmethod
    def from_array(cls, values) -> ArmConfig:
        return cls(*(float(v) for v in values))


@dataclass(frozen=True)
class Pose:
    """A solved posture: its angles, its joint positions (canonical frame, in
    :data:`JOINTS` order; "hand" is the hand's far end), the unit direction the forearm
    bends toward (perpendicular to the upper arm; defined even with a straight elbow, from
    γ), its strength category f_R, the wrist's two angles (:func:`hand_direction`) and the
    palm's roll about the hand's own axis (degrees, forearm twist; :mod:`.orient`: 0 unless
    the hand is matched to a target's orientation)."""

    config: ArmConfig
    joints: np.ndarray
    bend: np.ndarray
    f_r: int
    hand: tuple = (0.0, 0.0)
    roll: float = 0.0

    @property
    def wrist(self) -> np.ndarray:
        return self.joints[3]

    @property
    def elbow(self) -> np.ndarray:
        return self.joints[2]

    @property
    def shoulder(self) -> np.ndarray:
        return self.joints[1]


#: Arm lengths :func:`reach_sphere` adds beyond the farthest skin any pose can put anywhere
#: (a rig that moves its shoulder off the model's, the clearance kept, round-off): an
#: obstacle farther than that from every pose cannot change a plan.
REACH_SLACK = 0.5


def shape_reach(shape) -> float:
    """How far from the wrist any point of a hand shape (:attr:`ArmModel.hand_shape`)
    reaches: max over its capsules of max(|a|, |b|) + r; 0 for none."""
    return max((max(math.hypot(*a), math.hypot(*b)) + r for a, b, r in shape), default=0.0)


def reach_sphere(arm: ArmModel, slack: float = REACH_SLACK) -> tuple:
    """(world centre (3,), radius): a sphere holding every point of every pose the planner
    can give the arm, skin and hand included, with ``slack`` arm lengths to spare.

    The body rotation turns the chest about the canonical vertical axis through the
    origin (:func:`~.torso.rotate_about_spine`), so on every turn the shoulder
    :math:`s` and the sternum :math:`t` stay within

    .. math:: r_0 = \\max\\left(ρ_s,\\; ρ_t + |t_z - s_z|\\right),\\quad ρ = \\sqrt{x^2 + y^2}

    of :math:`c = (0, 0, s_z)`; the wrist within :math:`L_1 + L_2` of the shoulder, the
    hand's end within :math:`L_h` of the wrist, and each segment's skin within its radius
    (a hand's shape, :attr:`ArmModel.hand_shape`, within its own reach of the wrist, where
    that is farther):

    .. math:: R = r_0 + L_1 + L_2 + L_h + \\max(r_1, r_2, r_h) + \\text{slack}\\,(L_1 + L_2)

    What lies beyond R from c cannot touch the arm (the Blender layer leaves such objects
    out of the BVH)."""
    s, t = arm.shoulder, arm.sternum
    r0 = max(math.hypot(s[0], s[1]), math.hypot(t[0], t[1]) + abs(t[2] - s[2]))
    shape = shape_reach(arm.hand_shape)        # the hand as skinned (:mod:`.hand_shape`)
    radius = (r0 + arm.arm_length
              + max(arm.hand_length + max(arm.upper_arm_radius, arm.forearm_radius,
                                          arm.hand_radius), shape)
              + slack * arm.arm_length)
    return arm.to_world_points(np.array([0.0, 0.0, s[2]])), float(radius)


# --- the shoulder angle convention --------------------------------------------------------

def shoulder_angles(u):
    """(α, β) in degrees of upper-arm directions ``u`` (..., 3), chest frame.

    .. math:: θ = \\arccos(-u_z),\\quad (α, β) = θ \\frac{(u_x, u_y)}{\\sqrt{u_x^2 + u_y^2}}
    """
    u = np.asarray(u, dtype=float)
    theta = np.degrees(np.arccos(np.clip(-u[..., 2], -1.0, 1.0)))
    h = np.hypot(u[..., 0], u[..., 1])
    safe = np.where(h > 1e-12, h, 1.0)
    scale = np.where(h > 1e-12, theta / safe, 0.0)
    return scale * u[..., 0], scale * u[..., 1]


def elevation(alpha, beta):
    """Elevation θ of the upper arm from hanging: √(α² + β²) (degrees)."""
    return np.hypot(alpha, beta)


def upper_arm_direction(alpha, beta):
    """Inverse of :func:`shoulder_angles`: the unit direction (chest frame) with these
    angles, u = (sin θ cos φ, sin θ sin φ, -cos θ), θ = √(α² + β²), φ = atan2(β, α)."""
    alpha = np.asarray(alpha, dtype=float)
    beta = np.asarray(beta, dtype=float)
    theta = np.radians(np.hypot(alpha, beta))
    phi = np.arctan2(beta, alpha)
    s = np.sin(theta)
    return np.stack([s * np.cos(phi), s * np.sin(phi), -np.cos(theta)], -1)


def swing_reference(u):
    """The twist reference for upper-arm directions ``u`` (..., 3): forward (0, 1, 0)
    carried by the smallest rotation from hanging (0, 0, -1) to ``u``.

    Rodrigues' formula with axis (u_y, -u_x, 0)/|·| reduces to

    .. math:: r = \\left(\\frac{-u_x u_y}{1 - u_z},\\ -u_z + \\frac{u_x^2}{1 - u_z},\\ u_y\\right)

    a unit vector perpendicular to ``u``, singular only straight overhead (u_z = 1).
    """
    u = np.asarray(u, dtype=float)
    ux, uy, uz = u[..., 0], u[..., 1], u[..., 2]
    k = 1.0 / np.maximum(1.0 - uz, 1e-12)
    return np.stack([-ux * uy * k, -uz + ux * ux * k, uy], -1)


def twist_angle(u, bend):
    """γ (degrees) of a forearm bending toward unit ``bend`` (⊥ ``u``): the signed angle
    about ``-u`` from :func:`swing_reference` to ``bend``, internal rotation positive."""
    ref = swing_reference(u)
    axis = -np.asarray(u, dtype=float)
    sin = np.einsum("...i,...i->...", cross(ref, bend), axis)
    cos = np.einsum("...i,...i->...", ref, bend)
    return np.degrees(np.arctan2(sin, cos))


def bend_direction(u, gamma):
    """Unit direction the forearm bends toward for twist γ: the reference rotated by γ
    about ``-u`` (inverse of :func:`twist_angle`)."""
    ref = swing_reference(u)
    axis = -np.asarray(u, dtype=float)
    g = np.radians(np.asarray(gamma, dtype=float))[..., None]
    return ref * np.cos(g) + cross(axis, ref) * np.sin(g)


def hand_direction(upper, bend, forearm, wrist_bend_deg, wrist_side_deg):
    r"""Unit direction of the hand (wrist → hand end) for the wrist's two angles.

    The paper takes the wrist as the end-effector and leaves the hand free ("the position
    of the palm center is just a further search for a point on a sphere"). We model the
    hand as a segment that continues the forearm ``f`` at neutral and turns by
    ``wrist_bend`` in the elbow's plane (toward ``p = h × f``, where the elbow's hinge
    axis is ``h = u × b``) and by ``wrist_side`` across it (toward ``h``):

    .. math:: d = f \cos β_w \cos σ_w + p \sin β_w \cos σ_w + h \sin σ_w

    Forearm pronation is not modelled, so these are bends of the hand relative to the elbow
    plane rather than anatomical flexion and deviation; their ranges follow the AAOS wrist
    ranges (``Settings.wrist_bend_max``, ``Settings.wrist_side_max``). Vectors (3,).
    """
    u, b, f = (np.asarray(v, float).tolist() for v in (upper, bend, forearm))
    return np.array(hand_direction_floats(u, b, f, wrist_bend_deg, wrist_side_deg))


def hand_coefficients(wrist_bend_deg: float, wrist_side_deg: float) -> tuple:
    """(cos β_w cos σ_w, sin β_w cos σ_w, sin σ_w): the hand direction's components along
    the rows (f, p, h) of :func:`hand_basis` (:func:`hand_direction`)."""
    b, s = math.radians(wrist_bend_deg), math.radians(wrist_side_deg)
    return (math.cos(b) * math.cos(s), math.sin(b) * math.cos(s), math.sin(s))


def hand_basis(upper, bend, forearm) -> tuple:
    """The hand's frame at an arm pose, rows (f, p, h) as float triples: the forearm
    direction f, the in-plane direction p = h × f the hand bends toward, and the elbow's
    hinge axis h = normalize(u × b) (:func:`hand_direction`). Plain floats in and out (the
    planner asks for it at every pose it tries)."""
    (ux, uy, uz), (bx, by, bz), (fx, fy, fz) = upper, bend, forearm
    hx, hy, hz = uy * bz - uz * by, uz * bx - ux * bz, ux * by - uy * bx
    hn = max(math.sqrt(hx * hx + hy * hy + hz * hz), 1e-12)
    hx, hy, hz = hx / hn, hy / hn, hz / hn
    px, py, pz = hy * fz - hz * fy, hz * fx - hx * fz, hx * fy - hy * fx
    return (fx, fy, fz), (px, py, pz), (hx, hy, hz)


def hand_direction_floats(upper, bend, forearm, wrist_bend_deg, wrist_side_deg) -> tuple:
    """:func:`hand_direction` on plain floats: three (x, y, z) sequences in, a tuple out
    (the sampling planner's validity test runs it for every state it tests, where numpy
    costs more than the arithmetic)."""
    (fx, fy, fz), (px, py, pz), (hx, hy, hz) = hand_basis(upper, bend, forearm)
    cf, cp, ch = hand_coefficients(wrist_bend_deg, wrist_side_deg)
    return (fx * cf + px * cp + hx * ch, fy * cf + py * cp + hy * ch,
            fz * cf + pz * cp + hz * ch)


def hand_angles(upper, bend, forearm, direction):
    """The wrist's two angles (degrees) of a hand pointing along ``direction``: the inverse
    of :func:`hand_direction`, β_w = atan2(d·p, d·f), σ_w = asin(d·h). Used to start a
    motion from the hand a rig has, wherever it points (even beyond the wrist's range)."""
    u, b, f, d = (np.asarray(v, dtype=float) for v in (upper, bend, forearm, direction))
    f, p, h = (np.array(row) for row in hand_basis(u.tolist(), b.tolist(), f.tolist()))
    d = d / max(float(np.linalg.norm(d)), 1e-12)
    return (float(np.degrees(np.arctan2(d @ p, d @ f))),
            float(np.degrees(np.arcsin(np.clip(d @ h, -1.0, 1.0)))))


def hand_frame(pose: Pose) -> np.ndarray:
    """The hand's orientation at a pose, columns (d, g, d × g) (:func:`hand_orientation`)
    of its direction d (wrist → hand end) and the elbow's hinge axis — the frame the bake
    turns the hand bone by, so its change from frame to frame is the hand's whole turn,
    the roll of a twisting arm included."""
    s, e, w, h = pose.joints[1], pose.joints[2], pose.joints[3], pose.joints[4]
    d = (h - w) / max(float(np.linalg.norm(h - w)), 1e-12)
    return hand_orientation(d, cross(e - s, pose.bend))


def hand_orientation(d, hinge) -> np.ndarray:
    """Columns (d, g, d × g), (..., 3, 3), of hand directions ``d`` (..., 3), unit, with g
    the elbow's ``hinge`` axis (..., 3) made perpendicular to d and unit."""
    g = hinge - np.sum(hinge * d, axis=-1, keepdims=True) * d
    g = g / np.maximum(np.linalg.norm(g, axis=-1, keepdims=True), 1e-12)
    return np.stack([d, g, cross(d, g)], -1)


def roll_frames(frames, psi):
    """Frames (..., 3, 3) of columns (d, g, c) turned by ψ (degrees, (...)) about their own
    first column: F R_x(ψ), i.e. g' = g cos ψ + c sin ψ, c' = c cos ψ − g sin ψ (the palm's
    roll, :attr:`Pose.roll`)."""
    f = np.asarray(frames, dtype=float)
    p = np.radians(np.asarray(psi, dtype=float))[..., None]
    cos, sin = np.cos(p), np.sin(p)
    g, c = f[..., :, 1], f[..., :, 2]
    return np.stack([f[..., :, 0], g * cos + c * sin, c * cos - g * sin], -1)


def frame_angle(a, b):
    """The angle (degrees) of the rotation between two frames (..., 3, 3):
    θ = acos((tr(A Bᵀ) − 1) / 2)."""
    tr = np.einsum("...ij,...ij->...", a, b)
    return np.degrees(np.arccos(np.clip((tr - 1.0) / 2.0, -1.0, 1.0)))


def rolled_hand_frame(pose: Pose) -> np.ndarray:
    """The hand's frame at a pose (:func:`hand_frame`) turned by its palm's
    :attr:`~Pose.roll` (:func:`roll_frames`): its whole orientation in space."""
    f = hand_frame(pose)
    return roll_frames(f, pose.roll) if pose.roll else f


def frame_turn(a: Pose, b: Pose) -> float:
    """The angle (degrees) of the rotation that takes the hand of ``a`` to that of ``b``
    (:func:`rolled_hand_frame`)."""
    return float(frame_angle(rolled_hand_frame(b), rolled_hand_frame(a)))


def forward_kinematics(arm: ArmModel, configs):
    """Joint positions (..., 5, 3) and bend directions (..., 3), canonical frame, for
    configurations (..., 5) = (body rotation, α, β, γ, elbow) in degrees.

    .. math::
        s = R_z(θ_b)\\, s_0,\\quad e = s + L_1 R_z(θ_b) u(α, β),\\quad
        w = e + L_2 R_z(θ_b)(\\cos ε\\, u + \\sin ε\\, b(u, γ)),\\quad
        h = w + L_h (w - e)/L_2

    where ε is elbow flexion and b the bend direction.
    """
    c = np.asarray(configs, dtype=float)
    body, alpha, beta, gamma, flex = (c[..., i] for i in range(5))
    u = upper_arm_direction(alpha, beta)
    bend = bend_direction(u, gamma)
    eps = np.radians(flex)[..., None]
    f = u * np.cos(eps) + bend * np.sin(eps)
    rot = spine_rotation_matrix(body)
    u_c = np.einsum("...ij,...j->...i", rot, u)
    f_c = np.einsum("...ij,...j->...i", rot, f)
    bend_c = np.einsum("...ij,...j->...i", rot, bend)
    sternum = rotate_about_spine(arm.sternum, body)
    shoulder = rotate_about_spine(arm.shoulder, body)
    elbow = shoulder + arm.upper_arm_length * u_c
    wrist = elbow + arm.forearm_length * f_c
    hand = wrist + arm.hand_length * f_c
    return np.stack([sternum, shoulder, elbow, wrist, hand], -2), bend_c


def pose_from_config(arm: ArmModel, config: ArmConfig, f_r: int = -1,
                     hand=(0.0, 0.0)) -> Pose:
    """A :class:`Pose` from five angles (forward kinematics) and the wrist's two angles."""
    joints, bend = forward_kinematics(arm, config.as_array())
    if hand != (0.0, 0.0):
        s, e, w = joints[1], joints[2], joints[3]
        u = (e - s) / np.linalg.norm(e - s)
        f = (w - e) / np.linalg.norm(w - e)
        joints[4] = w + arm.hand_length * hand_direction(u, bend, f, *hand)
    return Pose(config, joints, bend, f_r, tuple(float(v) for v in hand))


def config_from_joints(arm: ArmModel, elbow, wrist, body_rotation=0.0, gamma_if_straight=0.0):
    """The five angles of a posture given by joint positions (canonical frame): the inverse
    of :func:`forward_kinematics`, used to read a rig's current pose.

    The shoulder is the arm's rest shoulder turned by ``body_rotation``. The elbow and
    wrist need not sit at exactly the arm's segment lengths (a rig's pose may stretch
    slightly): the directions are what count. With a straight elbow the twist is not
    observable and ``gamma_if_straight`` is used.
    """
    elbow = require_finite("elbow position", elbow)
    wrist = require_finite("wrist position", wrist)
    shoulder = rotate_about_spine(arm.shoulder, body_rotation)
    inverse = spine_rotation_matrix(body_rotation).T
    upper = inverse @ (elbow - shoulder)
    fore = inverse @ (wrist - elbow)
    for name, vec in (("upper arm", upper), ("forearm", fore)):
        if np.linalg.norm(vec) < 1e-9:
            raise ReachError(f"the {name} of arm '{arm.name}' has zero length in this pose")
    u = upper / np.linalg.norm(upper)
    f = fore / np.linalg.norm(fore)
    alpha, beta = shoulder_angles(u)
    flex = float(np.degrees(np.arccos(np.clip(u @ f, -1.0, 1.0))))
    perp = f - (f @ u) * u
    if np.linalg.norm(perp) < 1e-6:
        gamma = gamma_if_straight
    else:
        gamma = float(twist_angle(u, perp / np.linalg.norm(perp)))
    return ArmConfig(float(body_rotation), float(alpha), float(beta), gamma, flex)
