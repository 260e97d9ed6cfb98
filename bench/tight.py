"""Tight scenes (issue 14, item 1): does Reach find a path wherever one exists?

``python bench/tight.py`` generates a set of tight scenes from a seed — cubbies, slots,
holes in panels and narrow gaps beside the body, each sized to one body type's own limb
thickness — and plans each twice: OMPL's RRTConnect with a generous time budget
establishes whether a path exists, then Reach plans it. The goal: Reach succeeds on at
least 99 % of the scenes OMPL solves, with its median time well under OMPL's. It writes
``bench/tight.json`` (one record per scene) and prints a markdown table; ``make bench``
runs it as its step ``tight`` (:func:`bench_step`). ``--quick`` tries it out (20 scenes,
5 s for OMPL).

Arms (:data:`ARMS`)
-------------------
Each body type has its own proportions and real limb thickness: the standard figure
(:func:`reach_addon.samples.standard_arm`); a *bulky* figure, the same lengths with about
1.6 times the limb and torso radii; a long-forearm *robot* (upper arm 0.58, forearm 1.38,
hand 0.68 world units; radii 0.09, 0.35, 0.24) on a torso wide enough for that forearm to
hang beside it; and, read by the rig adapter (:func:`reach_addon.blender.rig.build`) from
the real rigs in ``tests/data/rigs``, Quaternius' *Female Casual*, the MakeHuman rig and
Cesium Man (their limb radii measured from their skin). Every scene is built in its arm's
canonical frame (x toward the arm's side, y forward, z up, origin on the spine at chest
height) and put into the world by the arm's own transform.

Scenes (:func:`generate`)
-------------------------
Every length is scaled by the arm's length ``L`` and by its limb radius ``R`` = the larger
of the forearm's and the hand's radius (both pass through the opening), plus the
planner's clearance margin ``c`` (``Settings.clearance`` × ``L``): the opening's narrow
width is ``w = 2 (R + c) f``, ``f`` drawn from [1.05, 1.8]. Depths are drawn in arm
lengths. A scene is accepted only if (checked, else it is drawn again from the same
random stream): the core's configuration generator finds a legal, clear pose with the
wrist on the target in that scene (so the target is within reach and in free space, and
OMPL's goal exists), that pose is a valid state by ``bench.ompl_race.Validity``, the start
pose is valid there too, and the target is at least ``R + c`` from every obstacle.

* **cubby** — an open-front box in a shelf of 3 × 3 such boxes (boards, a back panel),
  facing the arm: the box ``w`` across and 1.2–2.5 ``w`` the other way, the wrist 0.05–0.3
  ``L`` inside, the back panel beyond the hand's tip.
* **slot** — a wall 0.06–0.2 ``L`` thick, 1–1.8 ``L`` across, with a slot ``w`` wide and
  0.3–0.8 ``L`` (and 2.5–4 ``w``) long,
  horizontal or vertical; the target behind the wall (0.03–0.15 ``L``) or inside the slot.
* **hole** — a plate 0.01–0.04 ``L`` thick, 1–1.8 ``L`` across, with a rectangular
  (``w`` by 1–2.2 ``w``) or octagonal (``w`` across the flats) hole; the target 0.05–0.25
  ``L`` through it.
* **gap** — a column (0.1–0.25 ``L`` wide) or wall (0.35–0.8 ``L``), 0.4–1.3 ``L`` tall,
  standing beside the torso, its face ``w`` from the torso's surface; the target half-way
  across the gap,
  0.15–0.75 ``L`` below the shoulder, anywhere from beside-behind to beside-in-front.

The plate, wall and shelf face along the forearm of the pose the core's generator gives
for the target without the obstacle (so the opening lies across the way the arm would
come); the narrow direction is turned at random about that axis (cubby, hole) or kept
horizontal or vertical (slot).

Each side (:func:`plan_scene`)
------------------------------
* **OMPL**: RRTConnect in ``bench.ompl_race``'s joint space with its ``Validity`` (the
  core's acceptance), from the start pose to a goal region: the core generator's pose at
  the target and up to :data:`bench.ompl_race.GOAL_STATES` - 1 other clear swivel
  candidates of the same IK (Table 1's chest turn), each with the first hand direction of
  the generator's samples that is clear. No simplification (only existence is asked).
  Timed around ``solve`` alone; its budget (20 s) is CPU time of this process, so that a
  busy machine does not cut the search short.
* **Reach**: ``Planner(arm, obstacles, Settings()).plan(Task("reach", ...))``, timed around
  ``plan`` alone (the workspace grid, the paper's preprocessing, is built before and
  reported apart). Its path (every frame, linearly interpolated in joint space so that no
  joint — elbow, wrist, the hand's far end — moves more than 0.002 ``L`` between samples)
  is checked by ``ompl_race``'s independent check (actual contact, no margin): a success
  that touches an obstacle counts as a failure. OMPL's path is checked the same way. The
  method that found the path is ``plan.segments[0].method`` where the core reports one.

Both sides get the same planner object (same obstacles, same checker) and the same clocks:
``time.perf_counter`` (the table's times) and ``time.process_time`` (CPU time, recorded
too: on a loaded machine it is the steadier of the two).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

import bpy  # noqa: E402,F401  (mathutils for the obstacles' BVH)

from bench.ompl_race import (CLEARANCE_HORIZON, DENSE_SPACING,  # noqa: E402
                             JointSpace, Validity, densify, goal_rows, joints_of, pose_row,
                             prepare_query, rrt_connect, run_query)
from reach_addon.core import Planner, Settings, Task  # noqa: E402
from reach_addon.core.arm import ArmConfig, ArmModel, Capsule  # noqa: E402
from reach_addon.core.collision import Obstacles  # noqa: E402
from reach_addon.samples import HANGING, figure_transform, standard_arm  # noqa: E402
from verification.clearance import independent_check  # noqa: E402

FAMILIES = ("cubby", "slot", "hole", "gap")
SYNTHETIC_ARMS = ("standard", "bulky", "robot")
RIG_ARMS = ("quaternius", "gomakehuman", "cesium")
ARMS = SYNTHETIC_ARMS + RIG_ARMS
#: The range of the width factor f: an opening is 2 (R + c) f across.
FACTOR = (1.05, 1.8)
#: Scenes, OMPL's seconds per scene: the full run and ``--quick``.
DEFAULT_COUNT, DEFAULT_OMPL_TIME = 240, 20.0
QUICK_COUNT, QUICK_OMPL_TIME = 20, 5.0
#: Attempts at drawing one scene before giving up.
MAX_ATTEMPTS = 400
GOAL_RATE = 0.99


# --- the arms ------------------------------------------------------------------------------

def bulky_arm() -> ArmModel:
    """The standard figure's lengths with a heavy build: limbs and torso about 1.6 times
    as thick, shoulders wider to carry them."""
    caps = (
        Capsule("chest", (0, 0, -0.30), (0, 0, 0.0), 0.19, True),
        Capsule("pelvis", (0, 0, -0.65), (0, 0, -0.30), 0.20, False),
        Capsule("head", (0, 0.02, 0.16), (0, 0.02, 0.31), 0.11, True),
    )
    return ArmModel(
        sternum=np.array([0, 0.10, -0.02]), shoulder=np.array([0.25, 0.0, 0.0]),
        waist=np.array([0, 0, -0.45]), upper_arm_length=0.325, forearm_length=0.255,
        hand_length=0.19, upper_arm_radius=0.085, forearm_radius=0.068, hand_radius=0.052,
        to_world=figure_transform("right"), body_capsules=caps, side="right",
        name="bulky right arm")


def robot_arm() -> ArmModel:
    """A long-forearm robot: upper arm 0.58, forearm 1.38, hand 0.68 world units, radii
    0.09, 0.35, 0.24; a torso 0.7 across with the shoulder 0.85 out, so the thick forearm
    hangs clear of it."""
    caps = (
        Capsule("chest", (0, 0, -0.90), (0, 0, 0.0), 0.35, True),
        Capsule("pelvis", (0, 0, -1.80), (0, 0, -0.90), 0.38, False),
        Capsule("head", (0, 0.05, 0.45), (0, 0.05, 0.85), 0.25, True),
    )
    return ArmModel(
        sternum=np.array([0, 0.20, -0.05]), shoulder=np.array([0.85, 0.0, 0.0]),
        waist=np.array([0, 0, -1.30]), upper_arm_length=0.58, forearm_length=1.38,
        hand_length=0.68, upper_arm_radius=0.09, forearm_radius=0.35, hand_radius=0.24,
        to_world=figure_transform("right", (0.0, 0.0, 3.0)), body_capsules=caps,
        side="right", name="robot right arm")


_RIG_CACHE: dict = {}


def rig_arm(kind: str) -> ArmModel:
    """The right arm the rig adapter reads from one of the real rigs of
    ``tests/data/rigs`` at rest (loads it into an empty Blender file)."""
    if kind not in _RIG_CACHE:
        sys.path.insert(0, str(ROOT / "tests" / "blender"))
        import rigs

        from reach_addon.blender import rig as rig_mod

        armature = rigs.load(kind)
        rigs.rest_still(armature)
        _RIG_CACHE[kind] = rig_mod.build(armature, "right").arm
    return _RIG_CACHE[kind]


def make_arm(name: str) -> ArmModel:
    if name == "standard":
        return standard_arm()
    if name == "bulky":
        return bulky_arm()
    if name == "robot":
        return robot_arm()
    if name in RIG_ARMS:
        return rig_arm(name)
    raise ValueError(f"unknown arm {name!r}; choose from {', '.join(ARMS)}")


def limb_radius(arm: ArmModel) -> float:
    """The radius an opening is sized to: the thicker of the forearm and the hand."""
    return max(arm.forearm_radius, arm.hand_radius)


# --- meshes --------------------------------------------------------------------------------

def convex_prism(polygon_uv, depth_lo, depth_hi, origin, u, v, a):
    """Vertices (2n, 3) and outward triangles of a prism: a convex polygon (n, 2) in the
    plane spanned by ``u``, ``v`` through ``origin``, extruded along ``a`` from ``depth_lo``
    to ``depth_hi``."""
    poly = np.asarray(polygon_uv, float)
    n = len(poly)
    base = origin + poly[:, :1] * u + poly[:, 1:2] * v
    verts = np.concatenate([base + depth_lo * a, base + depth_hi * a])
    tris = [(0, k, k + 1) for k in range(1, n - 1)]
    tris += [(n, n + k + 1, n + k) for k in range(1, n - 1)]
    for k in range(n):
        j = (k + 1) % n
        tris += [(k, j, n + j), (k, n + j, n + k)]
    tris = np.array(tris)
    centre = verts.mean(0)
    p = verts[tris]
    normal = np.cross(p[:, 1] - p[:, 0], p[:, 2] - p[:, 0])
    flip = np.einsum("ij,ij->i", normal, p.mean(1) - centre) < 0
    tris[flip] = tris[flip][:, ::-1]
    return verts, tris


def rect(u0, u1, v0, v1):
    return [(u0, v0), (u1, v0), (u1, v1), (u0, v1)]


def ring(inner, outer):
    """Convex quads between an inner and an outer polygon of the same count (a plate
    with a hole): piece k spans inner edge k and outer edge k."""
    n = len(inner)
    return [[inner[k], inner[(k + 1) % n], outer[(k + 1) % n], outer[k]] for k in range(n)]


def polygon(across_flats, sides, roll=0.0, aspect=1.0):
    """A polygon with its flats ``across_flats`` apart (a rectangle ``across_flats`` by
    ``aspect`` times that for 4 sides)."""
    if sides == 4:
        h, k = 0.5 * across_flats, 0.5 * across_flats * aspect
        return rect(-h, h, -k, k)
    r = 0.5 * across_flats / math.cos(math.pi / sides)
    return [(r * math.cos(roll + (k + 0.5) * 2 * math.pi / sides),
             r * math.sin(roll + (k + 0.5) * 2 * math.pi / sides)) for k in range(sides)]


# --- scenes --------------------------------------------------------------------------------

@dataclass
class Scene:
    """One generated scene: canonical-frame prisms of one arm, the target, and what the
    generator promised (``gap_width`` = 2 (R + c) ``factor``)."""

    family: str
    arm_name: str
    seed: int
    arm: ArmModel
    target_c: np.ndarray
    start: ArmConfig
    parts: list                       # [(name, vertices (n, 3) canonical, triangles)]
    gap_width: float
    factor: float
    limb_radius: float
    margin: float
    depth: float                      # how far the wrist is past the opening's front (L)
    opening: np.ndarray               # the middle of the opening, w/2 from its nearest sides
    kind: str = ""                    # shape detail: "rect", "octagon", "horizontal", ...
    attempts: int = 1
    witness: np.ndarray | None = field(default=None, repr=False)

    @property
    def target(self) -> np.ndarray:
        """The target in world space."""
        return self.arm.to_world_points(self.target_c)

    def soup(self):
        """World vertices, triangles, owners, owner names of the obstacles."""
        verts, tris, owners, names = [], [], [], []
        offset = 0
        flip = np.linalg.det(self.arm.to_world[:3, :3]) < 0
        for k, (name, v, t) in enumerate(self.parts):
            verts.append(self.arm.to_world_points(v))
            tris.append((t[:, ::-1] if flip else t) + offset)
            owners += [k] * len(t)
            offset += len(v)
            names.append(name)
        return np.concatenate(verts), np.concatenate(tris), np.array(owners), names

    def triangles(self) -> np.ndarray:
        """World triangles (T, 3, 3), for the independent check."""
        verts, tris, _o, _n = self.soup()
        return verts[tris]

    def obstacles(self) -> Obstacles:
        return Obstacles.from_triangles(*self.soup())

    def record(self) -> dict:
        length = self.arm.arm_length
        return {"family": self.family, "kind": self.kind, "arm": self.arm_name,
                "seed": self.seed, "gap_width": self.gap_width,
                "gap_width_arm_lengths": self.gap_width / length, "factor": self.factor,
                "limb_radius": self.limb_radius, "margin": self.margin,
                "depth_arm_lengths": self.depth, "target": self.target.tolist(),
                "triangles": int(sum(len(t) for _n, _v, t in self.parts)),
                "attempts": self.attempts}


def start_config(arm: ArmModel, settings: Settings) -> ArmConfig:
    """The standard hanging start (:data:`reach_addon.samples.HANGING`), or the arm raised a
    little further out where the figure's own body is in its way (a thick arm)."""
    planner = Planner(arm, None, settings)
    validity = Validity(planner, JointSpace(arm, settings))
    for alpha in (0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0):
        config = ArmConfig(HANGING.body_rotation, HANGING.alpha + alpha, HANGING.beta,
                           HANGING.gamma, HANGING.elbow)
        if validity.valid(list(config.as_array()) + [0.0, 0.0]):
            return config
    raise ValueError(f"{arm.name}: no hanging start pose is clear of its own body")


def _unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def _across(a, toward):
    """The unit direction of ``toward`` made perpendicular to ``a`` (another if parallel)."""
    d = np.asarray(toward, float) - np.dot(toward, a) * a
    if np.linalg.norm(d) < 1e-6:
        d = np.cross(a, (1.0, 0.0, 0.0))
    return _unit(d)


def _front_target(rng, arm: ArmModel, lo=0.55, hi=0.9):
    """A target in front of the shoulder (canonical): azimuth −30…60° from forward toward
    the arm's side, elevation −40…30°, 0.55–0.9 arm lengths from the shoulder."""
    psi, eps = np.radians(rng.uniform(-30, 60)), np.radians(rng.uniform(-40, 30))
    rho = rng.uniform(lo, hi) * arm.arm_length
    d = np.array([math.sin(psi) * math.cos(eps), math.cos(psi) * math.cos(eps), math.sin(eps)])
    return arm.shoulder + rho * d


def _cubby(rng, arm, w, target, axis):
    L = arm.arm_length
    u = _across(axis, (0, 0, 1) if rng.random() < 0.5 else (1, 0, 0))
    u = _unit(math.cos(r := rng.uniform(-0.5, 0.5)) * u + math.sin(r) * np.cross(axis, u))
    v = np.cross(axis, u)
    h = w * rng.uniform(1.2, 2.5)                      # the box's other inner size
    e = min(rng.uniform(0.05, 0.3) * L, 0.7 * arm.forearm_length)
    board = rng.uniform(0.015, 0.04) * L
    depth = e + arm.hand_length + arm.hand_radius + 0.02 * L + rng.uniform(0.0, 0.15) * L
    i, j = rng.integers(0, 3, size=2)                   # the target's box in the 3 × 3 shelf
    pitch_u, pitch_v = w + board, h + board
    origin = target - e * axis                          # front face, centre of the box
    u_lo, v_lo = -0.5 * w - i * pitch_u - board, -0.5 * h - j * pitch_v - board
    u_hi, v_hi = u_lo + 3 * pitch_u + board, v_lo + 3 * pitch_v + board
    parts = [("back", *convex_prism(rect(u_lo, u_hi, v_lo, v_hi), depth, depth + board,
                                    origin, u, v, axis))]
    for k in range(4):
        x = u_lo + k * pitch_u
        parts.append((f"side {k}", *convex_prism(rect(x, x + board, v_lo, v_hi), 0.0, depth,
                                                 origin, u, v, axis)))
        y = v_lo + k * pitch_v
        parts.append((f"board {k}", *convex_prism(rect(u_lo, u_hi, y, y + board), 0.0, depth,
                                                  origin, u, v, axis)))
    return parts, e / L, "horizontal" if abs(u[2]) < abs(v[2]) else "vertical", origin


def _slot(rng, arm, w, target, axis):
    L = arm.arm_length
    kind = "horizontal" if rng.random() < 0.5 else "vertical"
    v = _across(axis, (0, 0, 1) if kind == "horizontal" else (1, 0, 0))  # across the slot
    u = np.cross(v, axis)                                               # along the slot
    thick = rng.uniform(0.06, 0.2) * L
    if rng.random() < 0.5:
        behind = rng.uniform(0.03, 0.15) * L
        kind += " behind"
    else:
        behind = -rng.uniform(0.3, 0.7) * thick                         # inside the slot
        kind += " inside"
    front = target - (behind + thick) * axis
    length = max(rng.uniform(0.3, 0.8) * L, rng.uniform(2.5, 4.0) * w)
    outer = rng.uniform(0.5, 0.9) * L
    centre = rng.uniform(-0.25, 0.25) * length                          # target along it
    inner = rect(-0.5 * length - centre, 0.5 * length - centre, -0.5 * w, 0.5 * w)
    out = rect(-max(outer, 0.5 * length + abs(centre) + 0.1 * L),
               max(outer, 0.5 * length + abs(centre) + 0.1 * L), -outer, outer)
    parts = [(f"wall {k}", *convex_prism(q, 0.0, thick, front, u, v, axis))
             for k, q in enumerate(ring(inner, out))]
    return parts, (behind + thick) / L, kind, front + 0.5 * thick * axis


def _hole(rng, arm, w, target, axis):
    L = arm.arm_length
    u = _across(axis, (0, 0, 1))
    roll = rng.uniform(0, math.pi)
    u, v = (math.cos(roll) * u + math.sin(roll) * np.cross(axis, u),
            -math.sin(roll) * u + math.cos(roll) * np.cross(axis, u))
    thick = rng.uniform(0.01, 0.04) * L
    through = min(rng.uniform(0.05, 0.25) * L, 0.6 * arm.forearm_length - thick)
    front = target - (through + thick) * axis
    outer = rng.uniform(0.5, 0.9) * L
    if rng.random() < 0.5:
        kind, inner = "rect", polygon(w, 4, aspect=rng.uniform(1.0, 2.2))
        out = rect(-outer, outer, -outer, outer)
    else:
        kind, inner = "octagon", polygon(w, 8)
        out = [(x * outer / (0.5 * w), y * outer / (0.5 * w)) for x, y in inner]
    parts = [(f"plate {k}", *convex_prism(q, 0.0, thick, front, u, v, axis))
             for k, q in enumerate(ring(inner, out))]
    return parts, (through + thick) / L, kind, front + 0.5 * thick * axis


def _torso_radius(arm: ArmModel, z: float) -> float:
    """The body's surface distance from the spine axis at height ``z`` (canonical): the
    thickest capsule there."""
    best = 0.0
    for c in arm.body_capsules:                    # vertical capsules on the spine axis
        lo, hi = sorted((float(c.a[2]), float(c.b[2])))
        dz = max(lo - z, z - hi, 0.0)
        if dz < c.radius:
            best = max(best, math.sqrt(c.radius ** 2 - dz ** 2))
    return best


def _gap(rng, arm, w):
    """A column or wall beside the torso, its face ``w`` from the torso's surface; the
    target half-way across. Returns (parts, target, kind) — the target is drawn here."""
    L = arm.arm_length
    z = arm.shoulder[2] - rng.uniform(0.15, 0.75) * L
    psi = np.radians(rng.uniform(-50, 60))            # from the side (x) toward forward (y)
    n = np.array([math.cos(psi), math.sin(psi), 0.0])
    t = np.array([-n[1], n[0], 0.0])
    surface = _torso_radius(arm, z)
    target = (surface + 0.5 * w) * n + np.array([0.0, 0.0, z])
    kind = "column" if rng.random() < 0.5 else "wall"
    width = rng.uniform(0.1, 0.25) * L if kind == "column" else rng.uniform(0.35, 0.8) * L
    shift = rng.uniform(-0.3, 0.3) * width
    below, above = rng.uniform(0.2, 0.5) * L, rng.uniform(0.2, 0.8) * L
    thick = rng.uniform(0.05, 0.15) * L
    origin = (surface + w) * n + np.array([0.0, 0.0, z])
    parts = [(kind, *convex_prism(rect(shift - 0.5 * width, shift + 0.5 * width, -below, above),
                                  0.0, thick, origin, t, np.array([0.0, 0.0, 1.0]), n))]
    return parts, target, kind


def generate(arm_name: str, arm: ArmModel, family: str, seed: int,
             settings: Settings | None = None, start: ArmConfig | None = None) -> Scene:
    """One scene of ``family`` for ``arm``, drawn from ``numpy.random.default_rng(seed)``
    (the same arguments give the same scene). Draws again until the scene keeps the
    promises of the module docstring."""
    settings = settings or Settings()
    start = start or start_config(arm, settings)
    rng = np.random.default_rng(seed)
    L = arm.arm_length
    R, c = limb_radius(arm), settings.clearance * L
    bare = Planner(arm, None, settings)
    for attempt in range(1, MAX_ATTEMPTS + 1):
        factor = float(rng.uniform(*FACTOR))
        w = 2.0 * (R + c) * factor
        if family == "gap":
            parts, target, kind = _gap(rng, arm, w)
            depth, opening = 0.0, target
        else:
            target = _front_target(rng, arm)
            free = bare.generator.solve(target)
            if free is None:
                continue
            axis = _unit(free.wrist - free.elbow)
            make = {"cubby": _cubby, "slot": _slot, "hole": _hole}[family]
            parts, depth, kind, opening = make(rng, arm, w, target, axis)
        scene = Scene(family, arm_name, seed, arm, np.asarray(target, float), start, parts,
                      w, factor, R, c, depth, np.asarray(opening, float), kind, attempt)
        witness = accepted(scene, settings)
        if witness is not None:
            scene.witness = witness
            return scene
    raise RuntimeError(f"no {family} scene for {arm_name} from seed {seed} in "
                       f"{MAX_ATTEMPTS} attempts")


def accepted(scene: Scene, settings: Settings):
    """The core generator's pose row at the target if the scene keeps its promises (the
    pose exists and is a valid state, the start is valid, the target is ``R + c`` clear of
    every obstacle and outside them), else None."""
    obstacles = scene.obstacles()
    world = scene.target
    if obstacles.point_inside(world) or \
            obstacles.distance(world, 2 * (scene.limb_radius + scene.margin)) \
            < scene.limb_radius + scene.margin:
        return None
    planner = Planner(scene.arm, obstacles, settings)
    validity = Validity(planner, JointSpace(scene.arm, settings))
    if not validity.valid(list(scene.start.as_array()) + [0.0, 0.0]):
        return None
    pose = planner.generator.solve(scene.target_c)
    if pose is None:
        return None
    row = pose_row(pose)
    return row if validity.valid(list(row)) else None


def scene_plan(count: int, seed: int, arms=ARMS, families=FAMILIES):
    """(arm, family, scene seed) of each of ``count`` scenes, scene ``k``'s seed ``seed`` ×
    100000 + ``k``. The cells arm × family come in turn, arms and families both changing
    from one scene to the next (scene ``k`` has arm ``k`` mod A and family ``k`` + ``k`` //
    lcm(A, F) mod F, which visits every cell once in A × F scenes), so that a short run
    already has every arm and every family."""
    n_a, n_f = len(arms), len(families)
    lcm = math.lcm(n_a, n_f)
    cells = [(arms[i % n_a], families[(i + i // lcm) % n_f]) for i in range(n_a * n_f)]
    return [(*cells[k % len(cells)], seed * 100_000 + k) for k in range(count)]


# --- planning ------------------------------------------------------------------------------

def ompl_solve(space: JointSpace, validity: Validity, start, goals, seed: int, time_s: float):
    """RRTConnect from ``start`` to any of ``goals`` (rows, degrees), for at most
    ``time_s`` seconds of this process's CPU time, not simplified (the race's query,
    :func:`bench.ompl_race.prepare_query` before the clock and
    :func:`~bench.ompl_race.run_query` on it). Returns (solved, (wall, CPU) seconds in
    ``solve``, states checked in it, path (K, 7) degrees or None)."""
    from ompl import base as ob
    from ompl import util as ou

    setup, state = rrt_connect(space, validity, seed, ou.LOG_ERROR)
    prepare_query(setup, state, start, goals)
    checks = validity.calls
    t0, c0 = time.perf_counter(), time.process_time()
    # the budget is CPU time, so that a busy machine does not cut OMPL's search short
    solved, path = run_query(
        setup, space,
        ob.PlannerTerminationCondition(lambda: time.process_time() - c0 >= time_s),
        simplify=False)
    elapsed, cpu = time.perf_counter() - t0, time.process_time() - c0
    return solved, (elapsed, cpu), validity.calls - checks, path


def plan_scene(scene: Scene, ompl_time_s: float, settings: Settings | None = None,
               ompl_seed: int | None = None, run_ompl: bool = True) -> dict:
    """OMPL's ground truth and Reach's plan for one scene (see the module docstring)."""
    settings = settings or Settings()
    arm = scene.arm
    tris = scene.triangles()
    planner = Planner(arm, scene.obstacles(), settings)
    space = JointSpace(arm, settings)
    validity = Validity(planner, space)
    check_hand = planner.generator.checker.check_hand
    start = pose_row(planner.generator.config_pose(scene.start))
    out = scene.record()

    # OMPL: the goal region outside the clock, then solve.
    if run_ompl:
        goals = goal_rows(planner, validity, scene.target_c)
        ok, secs, checks, path = ompl_solve(space, validity, start, goals,
                                            scene.seed if ompl_seed is None else ompl_seed,
                                            ompl_time_s)
        out.update(ompl_goals=len(goals), ompl_solved=ok, ompl_time_s=secs[0],
                   ompl_cpu_s=secs[1], ompl_validity_checks=checks, ompl_budget_s=ompl_time_s)
        if ok:
            m = contacts(space, tris, path, check_hand)
            out.update(ompl_collisions=m["collisions"], ompl_min_clearance=m["min_clearance"])

    # Reach: the workspace grid first (preprocessing), then the plan.
    out["reach_preprocess_time_s"] = planner.workspace.build_time_s
    task = Task("reach", scene.target[None], scene.start)
    t0, c0 = time.perf_counter(), time.process_time()
    plan = planner.plan(task)
    secs, cpu = time.perf_counter() - t0, time.process_time() - c0
    seg = plan.segments[0]
    out.update(reach_planned=bool(plan.success), reach_reason=plan.reason,
               reach_method=seg.method if plan.success else None,
               reach_time_s=secs, reach_cpu_s=cpu, reach_search_time_s=plan.stats.search_time_s,
               reach_nodes=plan.stats.nodes_searched,
               reach_sampling_states=int(plan.stats.sampling_states),
               reach_frames=len(plan.poses))
    m = contacts(space, tris, np.array([pose_row(p) for p in plan.poses]), check_hand)
    out.update(reach_collisions=m["collisions"], reach_arm_collisions=m["arm_collisions"],
               reach_min_clearance=m["min_clearance"])
    out["reach_success"] = bool(plan.success and m["collisions"] == 0)
    if plan.success and m["collisions"]:
        out["reach_reason"] = "touches (independent check)"
    out["reach_message"] = plan.message if not plan.success else ""
    return out


def contacts(space: JointSpace, tris, path, include_hand: bool) -> dict:
    """``ompl_race``'s independent check of a joint-space path, densely interpolated
    (:func:`~bench.ompl_race.densify`, :data:`~bench.ompl_race.DENSE_SPACING` arm lengths): samples
    touching an obstacle, those touching with the arm, least clearance (arm lengths)."""
    arm = space.arm
    length = arm.arm_length
    dense = densify(space, path, DENSE_SPACING * length)
    world = arm.to_world_points(joints_of(arm, dense))
    hits, arm_hits, least = independent_check(arm, world, tris, include_hand,
                                              CLEARANCE_HORIZON * length)
    return {"collisions": int(hits), "arm_collisions": int(arm_hits),
            "min_clearance": least / length, "samples": int(len(dense))}


# --- the run and its table -----------------------------------------------------------------

def run(count: int = DEFAULT_COUNT, seed: int = 0, ompl_time_s: float = DEFAULT_OMPL_TIME,
        arms=ARMS, families=FAMILIES, log=print, output: Path | None = None,
        ompl_from: dict | None = None) -> dict:
    """Generate and plan ``count`` scenes; write ``output`` (JSON) after every scene if
    given. Returns {"settings": ..., "scenes": [records], "summary": ...}.

    ``ompl_from``: a finished run (its JSON) whose OMPL side is taken instead of solving
    again, scene by scene (matched by arm, family and seed, and checked to be the same
    scene: its gap and target); only Reach plans. For a change to Reach alone: OMPL's side
    does not depend on Reach's settings, and it is most of an hour of the run. The record
    says so (``ompl_from``)."""
    settings = Settings()
    arm_models = {name: make_arm(name) for name in dict.fromkeys(a for a, _f, _s in
                                                                 scene_plan(count, seed, arms,
                                                                            families))}
    starts = {name: start_config(arm, settings) for name, arm in arm_models.items()}
    result = {"count": count, "seed": seed, "ompl_time_s": ompl_time_s,
              "reach_commit": git_commit(),
              "arms": {name: arm_record(arm, starts[name]) for name, arm in arm_models.items()},
              "scenes": []}
    earlier = {}
    if ompl_from is not None:
        result["ompl_from"] = ompl_from.get("source", "an earlier run")
        result["ompl_time_s"] = ompl_from["ompl_time_s"]
        earlier = {(r["arm"], r["family"], r["seed"]): r for r in ompl_from["scenes"]}
    t_all = time.perf_counter()
    for k, (arm_name, family, scene_seed) in enumerate(scene_plan(count, seed, arms, families)):
        scene = generate(arm_name, arm_models[arm_name], family, scene_seed, settings,
                         starts[arm_name])
        old = earlier.get((arm_name, family, scene_seed))
        if ompl_from is not None:
            same = scene.record()
            if old is None or (old["target"], old["gap_width"]) != (same["target"],
                                                                    same["gap_width"]):
                raise ValueError(f"scene {arm_name}/{family}/{scene_seed} is not in the "
                                 "earlier run, or is not the same scene there")
            row = plan_scene(scene, 0.0, settings, run_ompl=False)
            row.update({key: v for key, v in old.items() if key.startswith("ompl_")})
        else:
            row = plan_scene(scene, ompl_time_s, settings)
        result["scenes"].append(row)
        log(f"  [{k + 1}/{count}] {family:5s} {arm_name:11s} seed {scene_seed}: OMPL "
            f"{'solved' if row['ompl_solved'] else 'unsolved'} {row['ompl_time_s']:.2f} s; "
            f"Reach {'ok' if row['reach_success'] else row['reach_reason']} "
            f"({row['reach_method'] or '-'}) {row['reach_time_s']:.2f} s, "
            f"{row['reach_nodes']} nodes")
        if output is not None:
            result["summary"] = summary(result["scenes"])
            write_json(output, result)
    result["wall_time_s"] = time.perf_counter() - t_all
    result["summary"] = summary(result["scenes"])
    if output is not None:
        write_json(output, result)
    return result


def git_commit() -> str:
    """The commit Reach runs at (``-dirty`` with uncommitted changes), or '?'."""
    import subprocess

    try:
        return subprocess.run(["git", "describe", "--always", "--dirty"], cwd=ROOT,
                              capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "?"


def arm_record(arm: ArmModel, start: ArmConfig) -> dict:
    return {"name": arm.name, "arm_length": arm.arm_length,
            "lengths": [arm.upper_arm_length, arm.forearm_length, arm.hand_length],
            "radii": [arm.upper_arm_radius, arm.forearm_radius, arm.hand_radius],
            "limb_radius": limb_radius(arm), "start": start.as_array().tolist()}


def write_json(path: Path, data) -> None:
    path = Path(path)
    tmp = path.with_suffix(".json.tmp")
    tmp.write_text(json.dumps(data, indent=1))
    tmp.replace(path)


def _median(values):
    values = list(values)
    return statistics.median(values) if values else None


def _cell(rows) -> dict:
    solved = [r for r in rows if r["ompl_solved"]]
    reached = [r for r in solved if r["reach_success"]]
    methods: dict = {}
    for r in reached:
        methods[r["reach_method"]] = methods.get(r["reach_method"], 0) + 1
    return {"scenes": len(rows), "ompl_solved": len(solved), "reach_solved": len(reached),
            "reach_rate": len(reached) / len(solved) if solved else None,
            "reach_methods": methods,
            "reach_only": sum(1 for r in rows if r["reach_success"] and not r["ompl_solved"]),
            "reach_touching": sum(1 for r in rows if r["reach_planned"] and r["reach_collisions"]),
            "reach_median_s": _median(r["reach_time_s"] for r in solved),
            "reach_median_success_s": _median(r["reach_time_s"] for r in reached),
            "reach_median_search_s": _median(r["reach_search_time_s"] for r in solved),
            # the plan with the workspace grid built for it (built before the plan's clock)
            "reach_median_with_grid_s": _median(
                r["reach_time_s"] + r.get("reach_preprocess_time_s", 0.0) for r in solved),
            "ompl_median_s": _median(r["ompl_time_s"] for r in solved),
            "reach_median_cpu_s": _median(r.get("reach_cpu_s", math.nan) for r in solved),
            "ompl_median_cpu_s": _median(r.get("ompl_cpu_s", math.nan) for r in solved)}


def summary(rows) -> dict:
    """Per family and arm, per family, per arm and in total (see :func:`markdown`)."""
    cells = []
    for family in FAMILIES:
        for arm in ARMS:
            mine = [r for r in rows if r["family"] == family and r["arm"] == arm]
            if mine:
                cells.append({"family": family, "arm": arm, **_cell(mine)})
    by_family = [{"family": f, "arm": "all", **_cell([r for r in rows if r["family"] == f])}
                 for f in FAMILIES if any(r["family"] == f for r in rows)]
    by_arm = [{"family": "all", "arm": a, **_cell([r for r in rows if r["arm"] == a])}
              for a in ARMS if any(r["arm"] == a for r in rows)]
    total = {"family": "all", "arm": "all", **_cell(rows)}
    total["goal_rate"] = GOAL_RATE
    total["goal_met"] = total["reach_rate"] is not None and total["reach_rate"] >= GOAL_RATE
    failures = [{k: r.get(k) for k in ("seed", "family", "kind", "arm", "factor",
                                       "reach_reason", "reach_nodes", "reach_sampling_states",
                                       "reach_time_s", "ompl_time_s", "reach_message")}
                for r in rows if r["ompl_solved"] and not r["reach_success"]]
    return {"cells": cells, "by_family": by_family, "by_arm": by_arm, "total": total,
            "failures": failures}


def _ms(x):
    return "–" if x is None else f"{1000 * x:.0f}"


def _row(c) -> str:
    rate = "–" if c["reach_rate"] is None else f"{100 * c['reach_rate']:.1f} %"
    methods = ", ".join(f"{m} {n}" for m, n in sorted(c["reach_methods"].items())) or "–"
    return (f"| {c['family']} | {c['arm']} | {c['scenes']} | {c['ompl_solved']} | "
            f"{c['reach_solved']} ({rate}) | {methods} | {_ms(c['reach_median_s'])} | "
            f"{_ms(c.get('reach_median_search_s'))} | {_ms(c['ompl_median_s'])} |")


def markdown(result: dict) -> str:
    """The table: per family and arm, per family, per arm, and the total against the goal."""
    s = result["summary"]
    t = s["total"]
    lines = [f"## Tight scenes (issue 14: Reach on ≥ {100 * GOAL_RATE:.0f} % of what OMPL solves)",
             "",
             f"{t['scenes']} scenes from seed {result['seed']} (`bench/tight.py`, per scene in "
             f"`bench/tight.json`); OMPL RRTConnect with {result['ompl_time_s']:g} s of CPU time per "
             "scene decides whether a path exists. Reach's column counts its successes among the "
             "scenes OMPL solved, a success touching an obstacle by the independent check "
             "counted as a failure; medians over the scenes OMPL solved, in ms: Reach's whole "
             "plan (search, smoothing, timing, the hand pass), its search alone, OMPL's "
             "`solve` (no simplification)."
             + (f" Reach at `{result['reach_commit']}`." if result.get("reach_commit") else ""),
             "",
             "| family | arm | scenes | OMPL solved | Reach solved (of those) | by method | "
             "Reach plan ms | Reach search ms | OMPL ms |", "|---|---|---|---|---|---|---|---|---|"]
    lines += [_row(c) for c in s["cells"]]
    lines += [_row(c).replace(f"| {c['family']} | all |", f"| **{c['family']}** | all |")
              for c in s["by_family"]]
    lines += [_row(c).replace(f"| all | {c['arm']} |", f"| all | **{c['arm']}** |")
              for c in s["by_arm"]]
    lines.append(_row(t).replace("| all | all |", "| **total** | |"))
    rate = t["reach_rate"]
    lines += ["", f"Goal ≥ {100 * GOAL_RATE:.0f} %: **{'met' if t['goal_met'] else 'not met'}**"
              + ("" if rate is None else f" ({100 * rate:.1f} %)")
              + (f"; Reach's median {_ms(t['reach_median_s'])} ms "
                 f"({_ms(t.get('reach_median_with_grid_s'))} ms with its workspace grid) "
                 f"against OMPL's {_ms(t['ompl_median_s'])} ms (CPU time "
                 f"{_ms(t['reach_median_cpu_s'])} against {_ms(t['ompl_median_cpu_s'])} ms)"
                 if rate is not None else "")
              + f". Reach succeeded on {t['reach_only']} scene(s) OMPL did not solve; "
              f"{t['reach_touching']} plan(s) reported as reached touched an obstacle by the "
              "independent check."]
    if s["failures"]:
        lines += ["", "Scenes OMPL solves and Reach does not (nodes: positions the best-first "
                  "search tested; states: the sampling fallback's):", "",
                  "| seed | family | arm | gap factor | Reach's reason | nodes | states | "
                  "Reach s | OMPL s | Reach's message |", "|---|---|---|---|---|---|---|---|---|---|"]
        for f in s["failures"]:
            message = (f.get("reach_message") or "").split(";")[0].replace("|", "/")
            lines.append(f"| {f['seed']} | {f['family']} ({f['kind']}) | {f['arm']} | "
                         f"{f['factor']:.2f} | {f['reach_reason']} | {f['reach_nodes']} | "
                         f"{f.get('reach_sampling_states') or '–'} | {f['reach_time_s']:.2f} | "
                         f"{f['ompl_time_s']:.2f} | {message} |")
    return "\n".join(lines) + "\n"


def bench_step(folder: Path, log=print, count: int = DEFAULT_COUNT,
               ompl_time_s: float = DEFAULT_OMPL_TIME) -> dict:
    """``make bench``'s step: the full run, ``bench/tight.json``; returns what
    ``bench/run.py`` keeps in ``results.json`` (settings and summary)."""
    folder = Path(folder)
    result = run(count, ompl_time_s=ompl_time_s, log=log, output=folder / "tight.json")
    t = result["summary"]["total"]
    rate = "–" if t["reach_rate"] is None else f"{100 * t['reach_rate']:.1f} %"
    log(f"  Reach {t['reach_solved']}/{t['ompl_solved']} of the scenes OMPL solved ({rate}); "
        f"median Reach {_ms(t['reach_median_s'])} ms, OMPL {_ms(t['ompl_median_s'])} ms")
    return {k: result[k] for k in ("count", "seed", "ompl_time_s", "arms", "summary",
                                   "wall_time_s", "reach_commit") if k in result}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=None,
                        help=f"scenes (default {DEFAULT_COUNT}; --quick {QUICK_COUNT})")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--ompl-time", type=float, default=None,
                        help=f"OMPL's CPU seconds per scene (default {DEFAULT_OMPL_TIME:g}; "
                             f"--quick {QUICK_OMPL_TIME:g})")
    parser.add_argument("--quick", action="store_true", help="a short run to try it out")
    parser.add_argument("--arm", action="append", choices=ARMS, default=None,
                        help="only this arm (repeatable)")
    parser.add_argument("--family", action="append", choices=FAMILIES, default=None,
                        help="only this family (repeatable)")
    parser.add_argument("--no-rigs", action="store_true",
                        help="leave out the arms read from the real rigs")
    parser.add_argument("--output", default=str(ROOT / "bench" / "tight.json"))
    parser.add_argument("--ompl-from", metavar="JSON",
                        help="take OMPL's side from a finished run's JSON (same scenes) and "
                             "plan only Reach's")
    parser.add_argument("--table", metavar="JSON",
                        help="print the table of a finished run's JSON and plan nothing")
    args = parser.parse_args(argv)
    if args.table:
        result = json.loads(Path(args.table).read_text())
        result["summary"] = summary(result["scenes"])
        print(markdown(result))
        return 0
    count = args.count or (QUICK_COUNT if args.quick else DEFAULT_COUNT)
    ompl_time = args.ompl_time or (QUICK_OMPL_TIME if args.quick else DEFAULT_OMPL_TIME)
    arms = tuple(args.arm or (SYNTHETIC_ARMS if args.no_rigs else ARMS))
    families = tuple(args.family or FAMILIES)
    ompl_from = None
    if args.ompl_from:
        ompl_from = json.loads(Path(args.ompl_from).read_text())
        ompl_from["source"] = str(args.ompl_from)
    result = run(count, args.seed, ompl_time, arms, families, output=Path(args.output),
                 ompl_from=ompl_from)
    print()
    print(markdown(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
