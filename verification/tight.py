"""Tight scenes: cubbies, slots, holes and gaps sized to an arm's own limbs.

:func:`generate` draws one scene of a family (:data:`FAMILIES`) for a body type
(:data:`ARMS`, :func:`make_arm`) from ``numpy.random.default_rng(seed)``: the same
arguments give the same scene. Every length is scaled by the arm's length ``L`` (world
units) and its limb radius ``R`` (:func:`limb_radius`) plus the planner's clearance ``c``
(``Settings.clearance`` × ``L``): the opening's narrow width is ``w = 2 (R + c) f``, ``f`` in
:data:`FACTOR`. A scene is returned only once it keeps its promises (:func:`accepted`): the
core's generator finds a legal, clear pose on the target, that pose and the start are
valid states (:class:`verification.race.Validity`), and the target is ``R + c`` clear of
every obstacle. :func:`plan_scene` plans one with OMPL (does a path exist?) and with Reach,
both paths held to the independent check (:func:`verification.race.path_contacts`);
``bench/tight.py`` runs the set and writes its table. The families' shapes and why the
scenes are built so: ``docs/design.md``, *Tight scenes*.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import bpy  # noqa: F401  (mathutils for the obstacles' BVH)
import numpy as np

from reach_addon.core import Planner, Settings, Task
from reach_addon.core.arm import ArmConfig, ArmModel, Capsule
from reach_addon.core.collision import Obstacles
from reach_addon.core.sampling import pose_row
from reach_addon.samples import HANGING, figure_transform, standard_arm

from . import rig_builders
from .geometry import unit
from .race import (JointSpace, Validity, goal_rows, path_contacts, prepare_query, rrt_connect,
                   run_query)

FAMILIES = ("cubby", "slot", "hole", "gap")
SYNTHETIC_ARMS = ("standard", "bulky", "robot")
RIG_ARMS = ("quaternius", "gomakehuman", "cesium")
ARMS = SYNTHETIC_ARMS + RIG_ARMS
#: The range of the width factor f: an opening is 2 (R + c) f across.
FACTOR = (1.05, 1.8)
#: Attempts at drawing one scene before giving up.
MAX_ATTEMPTS = 400


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
        from reach_addon.blender import rig as rig_mod

        rigs, _synthetic = rig_builders()

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


def _across(a, toward):
    """The unit direction of ``toward`` made perpendicular to ``a`` (another if parallel)."""
    d = np.asarray(toward, float) - np.dot(toward, a) * a
    if np.linalg.norm(d) < 1e-6:
        d = np.cross(a, (1.0, 0.0, 0.0))
    return unit(d)


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
    u = unit(math.cos(r := rng.uniform(-0.5, 0.5)) * u + math.sin(r) * np.cross(axis, u))
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
            axis = unit(free.wrist - free.elbow)
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
    :func:`verification.race.prepare_query` before the clock and
    :func:`~verification.race.run_query` on it). Returns (solved, (wall, CPU) seconds in
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
    """OMPL's ground truth and Reach's plan for one scene, on one planner object (the same
    obstacles and checker for both).

    Returns the scene's :meth:`Scene.record` with, unless ``run_ompl`` is False, OMPL's
    side — ``ompl_goals`` (goal states), ``ompl_solved``, ``ompl_time_s`` / ``ompl_cpu_s``
    (wall and CPU seconds in ``solve``, at most ``ompl_time_s`` of CPU), the states it
    checked, and for a path its contacts and least clearance — and Reach's:
    ``reach_planned``, ``reach_reason``, ``reach_method``, ``reach_time_s`` / ``reach_cpu_s``
    (around ``plan`` alone; its workspace grid, built before, is
    ``reach_preprocess_time_s``), its search time, nodes, sampling states and frames, the
    independent check's contacts and least clearance (arm lengths), ``reach_success``
    (planned and touching nothing) and ``reach_message``. ``ompl_seed``: OMPL's seed (by
    default the scene's)."""
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
            m = path_contacts(space, tris, path, check_hand)
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
    m = path_contacts(space, tris, np.array([pose_row(p) for p in plan.poses]), check_hand)
    out.update(reach_collisions=m["collisions"], reach_arm_collisions=m["arm_collisions"],
               reach_min_clearance=m["min_clearance"])
    out["reach_success"] = bool(plan.success and m["collisions"] == 0)
    if plan.success and m["collisions"]:
        out["reach_reason"] = "touches (independent check)"
    out["reach_message"] = plan.message if not plan.success else ""
    return out
