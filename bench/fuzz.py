"""Fuzz campaign: seeded scenes, baked the way a user bakes them, every outcome classified.

``make fuzz`` (``python bench/fuzz.py --count 10000 --jobs 2 --out bench/fuzz.json``) turns
each seed into a scene (:func:`generate`: numpy ``default_rng(seed)``, nothing else), builds
it in Blender around a synthetic or real rig (:func:`build`), saves it, and bakes it twice
with the command line in-process (``reach_addon.cli.main(["bake", ...])``, the code
``python -m reach_addon bake`` runs). Each outcome is then one of:

``success_verified``
    every task reached: an independent check (:func:`verify`) finds the arm clear at every
    frame and sub-frame instant, hand included, and the wrist on the target on the last
    frame;
``failure_with_reason``
    a task failed with a reason of :data:`reach_addon.core.REASONS` and a message, or the
    command refused the input (exit status 2) with one line naming what is wrong;

or a bug: ``escaped_exception`` (an exception left ``cli.main``, or the worker process
died), ``timeout``, ``success_but_collides``, ``success_off_target``, ``input_changed`` (the
input file or a library it links changed), ``nondeterministic`` (two bakes of the same file
keyed different values, compared byte for byte, or ended differently), ``unclear_failure``
(a failure without a known reason, or a refusal that does not name the object at fault),
``false_refusal`` (a failure whose reason the cross-check below contradicts); and
``generator_error`` for a fault of this harness, not of Reach.

The refusal cross-check
-----------------------
A failure with a reason is a claim, so it is checked too (:func:`cross_check`,
:mod:`verification.refusal`): for ``no_path``, ``arm_does_not_fit``, ``needs_lean``,
``needs_step`` and ``out_of_reach`` OMPL's RRTConnect searches the planner's own problem
(its joint space, state test and obstacles, rebuilt by the pipeline's readers) toward a
goal region of valid IK states at the target — none at all confirms the refusal at once,
otherwise it searches for ``--cross-check-budget`` seconds (10) and a path found is a
false refusal; ``start_in_collision`` is checked on Blender's evaluated skin of the arm
and hand against the obstacles' triangles. fuzz.json counts the refusals decided
(``refusals_cross_checked``), the ``false_refusals`` (each listed with its seed) and, per
reason, every verdict with the check's median and largest time. The quick scenes of the
tests' subset starve the planner on purpose (``QUICK_SETTINGS``), so there the search
also stops after the scene's own sampling budget of states.

The independent check
---------------------
It shares no code with the planner. The baked file is opened and evaluated by Blender
(``scene.frame_set(f, subframe=s)``) at every frame of each successful task and at
``--subframes`` instants between frames. At each instant the arm's five joints are read
from the evaluated bones — sternum (the clavicle's head), shoulder, elbow, wrist and the
hand's far end, carried by their bones — and the four segments (clavicle, upper arm,
forearm, hand; the rig model's radii; the hand left out only where the bake was told not
to check it, ``--no-check-hand``) are measured against the triangles of the evaluated
meshes of the scene's obstacles by exact segment–triangle distance in numpy
(:func:`verification.clearance.independent_check`). Which objects are obstacles comes from the
scene's description, by the README's rules (visible objects with faces, not the
character, not a target), not from Reach's gathering. A start pose that already touches
something may stay in contact only while the motion leaves it (the planner moves out of
contact first, as documented); after the first clear instant every instant must be
clear. Triangles without area are left out: they have no surface to touch.

Scenes are placed in the rig's own body frame and sized by its own arm length, so they
mean the same at any scale and orientation: boxes, planes, thin walls, open and
non-manifold meshes, meshes of no size, a room round the character, a floor; armatures
scaled 0.01–100, rotated, mirrored, scaled non-uniformly (refused, by design); synthetic
rigs in T, A or arms-down rest poses, their elbows straight or bent up to 25° any way, the
forearm 0.6–2.5 times the upper arm, hands of one bone, a mitten, five fingers or sibling
palms, rolled against the forearm up to 90°, any bone roll convention, rigid parts
parented to bones instead of a skin (a stream of their own, :func:`_rig_shape`); targets on
moving objects and on the character's own bones, on or inside its body, out of reach;
animated, hidden and disabled obstacles, linked library data, NaN and infinite
locations. :data:`FEATURES` lists them; ``bench/fuzz.json`` counts outcomes per feature.

Reproduce one scene: ``python bench/fuzz.py --seed0 SEED --count 1 --keep DIR`` keeps
its files (``input.blend``, the two outputs, reports) and prints its description.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import math
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import traceback
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

#: Every outcome, in the order fuzz.json lists them, with what it means.
CATEGORIES = {
    "success_verified": "every task reached; clear at every frame and sub-frame instant and "
                        "the wrist on the target (independent check)",
    "failure_with_reason": "a task failed with a documented reason, or the input was refused "
                           "(exit 2) with a message naming what is wrong",
    "escaped_exception": "an exception escaped the command (or the process died)",
    "timeout": "the scene did not finish within the time limit",
    "success_but_collides": "reported success, but the independent check finds arm or hand "
                            "touching an obstacle at some instant",
    "success_off_target": "reported success, but the wrist is not on the target on the last "
                          "frame",
    "input_changed": "the input file (or a library it links) changed",
    "nondeterministic": "two bakes of the same file keyed different values or ended "
                        "differently",
    "unclear_failure": "a failure without a documented reason, or a refusal that does not "
                       "name the object at fault",
    "generator_error": "the fuzz harness itself failed to build or check the scene (not "
                       "Reach)",
    "false_refusal": "a task failed with a reason that the independent cross-check "
                     "contradicts (a clear path exists, or the start's arm and hand skin are "
                     "clear)",
}
GOOD = ("success_verified", "failure_with_reason")

#: Scene features (what a scene has); fuzz.json counts outcomes per feature.
FEATURES = (
    "rig_synthetic", "rig_real", "rig_lying", "rig_no_clavicle", "rig_decoy", "rig_no_skin",
    "scale_tiny", "scale_huge", "scale_other", "rotated", "mirrored", "non_uniform_scale",
    "non_uniform_parent", "armature_parented", "translated",
    "task_reach", "task_sequence", "task_guided", "task_chase", "several_targets",
    "arm_auto", "arm_left", "arm_right", "frame_start_flag", "frame_start_not_1",
    "bake_closest", "new_action", "no_chest_rotation", "duration", "obstacle_collection",
    "odd_names", "settings",
    "target_reachable", "target_far", "target_inside_body", "target_on_body",
    "target_at_wrist", "target_across_body", "target_behind", "target_overhead",
    "target_moving_parent", "target_on_bone", "target_nan", "target_inf",
    "box", "plane", "thin_wall", "open_mesh", "tube", "non_manifold", "flipped_faces",
    "zero_scale", "flat_scale", "collapsed_mesh", "edges_only", "empty_mesh", "dense_mesh",
    "modifier", "room", "floor", "touching_start",
    "animated_obstacle", "moving_parent_obstacle", "hidden", "disabled", "excluded_collection",
    "hidden_collection", "render_hidden", "linked_instance", "linked_mesh",
    "linked_armature", "obstacle_nan", "obstacle_inf", "armature_nan", "vertex_nan",
    "no_obstacles", "body_moves", "euler_bones",
    "rig_t_pose", "rig_arms_down", "rig_straight_elbow", "rig_elbow_turned", "rig_hand_roll",
    "rig_bone_roll", "rig_mitten", "rig_fingers", "rig_palms", "rig_rigid", "rig_long_forearm",
    "rig_short_forearm",
)

SYNTH_MAPS = ("mixamo", "vrm", "unity", "spaced", "makehuman", "unreal", "plain", "numbered")
REAL_RIGS = ("quaternius", "gomakehuman", "metarig", "cesium", "rigify")
ODD_NAMES = ("Tasse à café", 'Cup "blue"', "obj.001", "Ziel (1)", "杯子", "a b  c", "Cup'")
MESH_KINDS = ("box", "plane", "thin_wall", "open_mesh", "tube", "non_manifold",
              "flipped_faces", "zero_scale", "flat_scale", "collapsed_mesh", "edges_only",
              "empty_mesh", "dense_mesh", "modifier", "linked_instance", "linked_mesh")
MESH_WEIGHTS = (24, 8, 8, 6, 4, 5, 3, 2, 2, 2, 2, 2, 3, 4, 4, 3)
#: Meshes without faces or without area: never obstacles, so never checked.
NO_SURFACE = {"edges_only", "empty_mesh", "zero_scale", "collapsed_mesh"}
#: Share of scenes whose bones all rotate in an Euler order (feature ``euler_bones``).
EULER_BONES_SHARE = 0.05
#: Bone roll conventions of the synthetic rigs (``synthetic.humanoid(roll=...)``: every
#: bone's Z axis turned toward this construction axis; None keeps Blender's default).
BONE_ROLLS = (None, (0.0, 0.0, 1.0), (0.0, -1.0, 0.0), (0.0, 0.0, -1.0), (1.0, 0.0, 0.0))
#: Sub-frame instants checked between two frames (besides the frames themselves).
SUBFRAMES = 3
#: Seconds the cross-check's OMPL search may take per refusal where a goal region exists
#: (``verification.refusal``; ``--cross-check-budget``).
CROSS_CHECK_BUDGET_S = 10.0
#: Planner settings of the quick scenes (the tests' subset): smaller search budgets.
QUICK_SETTINGS = {"node_budget": 1500, "stall_budget": 400, "sampling_budget": 3000,
                  "hand_grid_step": 10.0}


# --- the scene description: seed -> plain data -------------------------------------------

def _pick(rng, items, weights=None):
    if weights is None:
        return items[int(rng.integers(len(items)))]
    p = np.asarray(weights, dtype=float)
    return items[int(rng.choice(len(items), p=p / p.sum()))]


def _unit(v):
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _random_rotation(rng) -> list:
    """A uniformly random rotation as a quaternion (w, x, y, z)."""
    q = rng.normal(size=4)
    return (q / np.linalg.norm(q)).tolist()


def _quat_matrix(q) -> np.ndarray:
    w, x, y, z = q
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
        [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
        [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])


def _direction(rng, yaw_deg, pitch_deg) -> list:
    """Body-frame unit vector (side, forward, up) at a yaw from forward toward the side
    and a pitch up from horizontal."""
    yaw, pitch = math.radians(yaw_deg), math.radians(pitch_deg)
    return [math.cos(pitch) * math.sin(yaw), math.cos(pitch) * math.cos(yaw), math.sin(pitch)]


def _target(rng, features: set, index: int, allow_parent: bool) -> dict:
    """One target: where (body frame of the reaching shoulder, arm lengths), parent, NaN."""
    kind = _pick(rng, ("reachable", "far", "inside_body", "on_body", "at_wrist",
                       "across_body", "behind", "overhead"), (64, 6, 4, 4, 3, 7, 6, 6))
    t = {"kind": kind, "index": index}
    if kind == "reachable":
        t["at"] = "shoulder"
        t["dir"] = _direction(rng, rng.uniform(-40, 90), rng.uniform(-60, 45))
        t["dist"] = float(rng.uniform(0.3, 0.95))
    elif kind == "far":
        t["at"] = "shoulder"
        t["dir"] = _direction(rng, rng.uniform(-60, 120), rng.uniform(-70, 70))
        t["dist"] = float(rng.uniform(1.1, 3.0))
    elif kind == "inside_body":
        t["at"] = _pick(rng, ("chest", "head", "pelvis", "shoulder_other"))
        t["dir"], t["dist"] = [0.0, 0.0, 0.0], 0.0
    elif kind == "on_body":
        t["at"] = _pick(rng, ("chest_front", "shoulder", "elbow", "belly_front"))
        t["dir"], t["dist"] = [0.0, 0.0, 0.0], 0.0
    elif kind == "at_wrist":
        t["at"] = "wrist"
        t["dir"], t["dist"] = [0.0, 0.0, 0.0], 0.0
    elif kind == "across_body":
        t["at"] = "shoulder"
        t["dir"] = _direction(rng, rng.uniform(-110, -50), rng.uniform(-40, 30))
        t["dist"] = float(rng.uniform(0.4, 1.0))
    elif kind == "behind":
        t["at"] = "shoulder"
        t["dir"] = _direction(rng, rng.uniform(100, 180) * _pick(rng, (1, -1)),
                              rng.uniform(-50, 30))
        t["dist"] = float(rng.uniform(0.3, 0.9))
    else:   # overhead
        t["at"] = "shoulder"
        t["dir"] = _direction(rng, rng.uniform(-30, 60), rng.uniform(55, 90))
        t["dist"] = float(rng.uniform(0.4, 0.95))
    features.add(f"target_{kind}")
    t["parent"] = None
    if allow_parent:
        r = rng.random()
        if r < 0.14:
            t["parent"] = {"kind": "moving", "delta": (rng.normal(size=3) * 0.25).tolist(),
                           "spin_deg": float(rng.uniform(-60, 60)) if rng.random() < 0.4 else 0.0,
                           "frames": int(rng.integers(12, 40))}
            features.add("target_moving_parent")
        elif r < 0.24:
            t["parent"] = {"kind": "bone", "role": _pick(
                rng, ("chest", "neck", "hips", "other_hand", "own_hand", "own_forearm"),
                (4, 2, 3, 2, 1, 1))}
            features.add("target_on_bone")
    t["nan"] = None
    r = rng.random()
    if r < 0.025:
        t["nan"] = "nan"
        features.add("target_nan")
    elif r < 0.04:
        t["nan"] = "inf"
        features.add("target_inf")
    return t


def _obstacle(rng, features: set, index: int) -> dict:
    kind = _pick(rng, MESH_KINDS, MESH_WEIGHTS)
    features.add(kind)
    o = {"kind": kind, "index": index}
    placement = _pick(rng, ("across", "near_target", "around", "under_hand"), (50, 22, 20, 8))
    if placement == "under_hand":
        features.add("touching_start")
    o["placement"] = placement
    o["t"] = float(rng.uniform(0.3, 0.85))                      # along the wrist-target line
    o["jitter"] = (rng.normal(size=3) * 0.08).tolist()
    o["target"] = 0
    o["around"] = [float(rng.uniform(-0.3, 1.0)), float(rng.uniform(0.35, 1.2)),
                   float(rng.uniform(-0.8, 0.6))]
    thin = kind == "thin_wall"
    size = rng.uniform(0.06, 0.4, size=3)
    if kind in ("plane", "thin_wall", "modifier"):
        size[2] = rng.uniform(0.001, 0.012) if thin else 1.0
    o["size"] = size.tolist()
    o["rotation"] = _random_rotation(rng) if rng.random() < 0.5 else None
    o["face_path"] = rng.random() < 0.6           # turned square across the path
    o["drop_faces"] = sorted(rng.choice(6, size=int(rng.integers(1, 4)), replace=False).tolist())
    o["flip_faces"] = sorted(rng.choice(6, size=int(rng.integers(1, 4)), replace=False).tolist())
    o["modifier"] = _pick(rng, ("SOLIDIFY", "ARRAY", "SUBSURF", "MIRROR"))
    vis = _pick(rng, ("visible", "hidden", "disabled", "excluded_collection",
                      "hidden_collection", "render_hidden"), (80, 5, 5, 3, 3, 4))
    o["visibility"] = vis
    if vis != "visible":
        features.add(vis)
    o["animated"] = None
    r = rng.random()
    if r < 0.10:
        o["animated"] = {"kind": "keys", "delta": (rng.normal(size=3) * 0.3).tolist(),
                         "spin_deg": float(rng.uniform(-90, 90)), "frames": int(rng.integers(8, 40))}
        features.add("animated_obstacle")
    elif r < 0.14:
        o["animated"] = {"kind": "parent", "delta": (rng.normal(size=3) * 0.3).tolist(),
                         "spin_deg": 0.0, "frames": int(rng.integers(8, 40))}
        features.add("moving_parent_obstacle")
    o["nan"] = None
    r = rng.random()
    if r < 0.02:
        o["nan"] = "nan"
        features.add("obstacle_nan")
    elif r < 0.04:
        o["nan"] = "inf"
        features.add("obstacle_inf")
    elif r < 0.05 and kind not in ("linked_instance", "linked_mesh", "empty_mesh"):
        o["nan"] = "vertex"
        features.add("vertex_nan")
    return o


def generate(seed: int, quick: bool = False, shapes: bool = True) -> dict:
    """The scene of ``seed``: plain data (JSON), the same for the same seed on every
    machine. Positions are in the reaching shoulder's body frame (side, forward, up), in
    the rig's arm lengths; :func:`build` makes them world positions.

    ``quick``: the same scene made cheaper to run (the fixed-seed subset of the tests):
    smaller search budgets, Rigify's metarig instead of the generated rig (which takes
    seconds to generate and to evaluate); every feature stays.

    ``shapes`` False: the synthetic rigs of the campaigns before their shapes varied (A
    pose, the elbow bent 30° forward, one hand bone, the standard proportions), so that a
    seed those campaigns found replays its own scene; every other draw is the same."""
    rng = np.random.default_rng(seed)
    features: set = set()
    spec: dict = {"seed": int(seed)}

    # the character
    if rng.random() < 0.72:
        rig = {"kind": "synthetic", "map": _pick(rng, SYNTH_MAPS),
               "skin": bool(rng.random() < 0.85), "skin_radius": float(rng.uniform(0.025, 0.06)),
               "decoy": _pick(rng, (None, "ik", "twin", "driver"), (85, 5, 5, 5)),
               "clavicle": bool(rng.random() >= 0.1), "twist": bool(rng.random() < 0.1),
               "lying": bool(rng.random() < 0.08), "facing": _pick(rng, ("-Y", "+Y"), (8, 2)),
               "own_scale": float(np.exp(rng.uniform(-0.7, 0.7))) if rng.random() < 0.2 else 1.0}
        if rig["decoy"] is not None and not rig["skin"]:
            rig["decoy"] = None      # a decoy can only be told apart by the skin
        features.add("rig_synthetic")
        features |= {f for f, on in (("rig_lying", rig["lying"]), ("rig_no_clavicle", not rig["clavicle"]),
                                     ("rig_decoy", rig["decoy"] is not None),
                                     ("rig_no_skin", not rig["skin"])) if on}
    else:
        rig = {"kind": _pick(rng, REAL_RIGS, (30, 25, 25, 15, 5))}
        features.add("rig_real")
    spec["rig"] = rig
    spec["linked_armature"] = bool(rng.random() < 0.02)
    if spec["linked_armature"]:
        features.add("linked_armature")

    # the world transform of everything (the "stage"), and the armature's own oddities
    r = rng.random()
    scale = float(np.exp(rng.uniform(math.log(0.01), math.log(100)))) if r < 0.5 else 1.0
    if scale < 0.1:
        features.add("scale_tiny")
    elif scale > 10:
        features.add("scale_huge")
    elif scale != 1.0:
        features.add("scale_other")
    r = rng.random()
    if r < 0.35:
        rotation = None
    elif r < 0.65:
        yaw = rng.uniform(0, 2 * math.pi)
        rotation = [math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)]
    else:
        rotation = _random_rotation(rng)
    if rotation is not None:
        features.add("rotated")
    mirror = _pick(rng, (None, 0, 1, 2), (88, 4, 4, 4))
    if mirror is not None:
        features.add("mirrored")
    translate = (rng.normal(size=3) * rng.uniform(0, 8)).tolist() if rng.random() < 0.5 else [0, 0, 0]
    if any(translate):
        features.add("translated")
    spec["stage"] = {"scale": scale, "rotation": rotation, "mirror": mirror,
                     "translate": translate}
    spec["armature_parented"] = bool(rng.random() < 0.2)
    spec["non_uniform"] = None
    r = rng.random()
    if r < 0.04:
        spec["non_uniform"] = {"on": "armature", "scale": rng.uniform(0.6, 1.6, size=3).tolist()}
        features.add("non_uniform_scale")
    elif r < 0.06:
        spec["non_uniform"] = {"on": "parent", "scale": rng.uniform(0.6, 1.6, size=3).tolist()}
        spec["armature_parented"] = True
        features.add("non_uniform_parent")
    if spec["armature_parented"]:
        features.add("armature_parented")
    spec["armature_nan"] = _pick(rng, (None, "nan", "inf"), (98.5, 1, 0.5))
    if spec["armature_nan"]:
        features.add("armature_nan")
    if spec["linked_armature"]:
        spec["stage"] = {"scale": 1.0, "rotation": None, "mirror": None, "translate": [0, 0, 0]}
        spec["armature_parented"], spec["non_uniform"], spec["armature_nan"] = False, None, None
        features -= {"scale_tiny", "scale_huge", "scale_other", "rotated", "mirrored",
                     "translated", "armature_parented", "non_uniform_scale",
                     "non_uniform_parent", "armature_nan"}

    # the task
    task = _pick(rng, ("reach", "sequence", "guided", "chase"), (58, 14, 10, 18))
    features.add(f"task_{task}")
    spec["task"] = task
    spec["side"] = _pick(rng, ("right", "left"), (7, 3))       # the shoulder the scene is round
    spec["arm"] = _pick(rng, ("auto", spec["side"], "right", "left"), (4, 4, 1, 1))
    features.add(f"arm_{spec['arm']}")
    if task == "chase":
        n_targets = 1
    elif task == "reach":
        n_targets = 1 if rng.random() < 0.8 else int(rng.integers(2, 4))
    else:
        n_targets = int(rng.integers(1, 4))
    if n_targets > 1:
        features.add("several_targets")
    targets = []
    for i in range(n_targets):
        t = _target(rng, features, i, allow_parent=True)
        if task == "chase" and i == 0 and rng.random() < 0.85:
            if t["parent"] is None or t["parent"]["kind"] != "moving":
                t["parent"] = {"kind": "moving", "delta": (rng.normal(size=3) * 0.25).tolist(),
                               "spin_deg": 0.0, "frames": int(rng.integers(12, 40))}
                features.add("target_moving_parent")
        names = rng.random() < 0.1
        t["name"] = (_pick(rng, ODD_NAMES) + (f" {i}" if i else "")) if names else f"FzTarget{i}"
        if names:
            features.add("odd_names")
        targets.append(t)
    spec["targets"] = targets
    frame = int(rng.integers(-5, 40)) if rng.random() < 0.25 else 1
    if frame != 1:
        features.add("frame_start_not_1")
    spec["frame_current"] = frame
    spec["frame_start_flag"] = int(frame + rng.integers(-3, 4)) if rng.random() < 0.25 else None
    if spec["frame_start_flag"] is not None:
        features.add("frame_start_flag")
        if spec["frame_start_flag"] != 1:
            features.add("frame_start_not_1")
    spec["bake_closest"] = bool(rng.random() < 0.15)
    spec["new_action"] = bool(rng.random() < 0.12)
    spec["no_chest_rotation"] = bool(rng.random() < 0.1)
    spec["duration"] = float(rng.uniform(0.3, 1.6)) if rng.random() < 0.12 else None
    features |= {f for f in ("bake_closest", "new_action", "no_chest_rotation") if spec[f]}
    spec["settings"] = {}
    r = rng.random()
    if r < 0.04:
        spec["settings"]["step"] = 0.03
    elif r < 0.07:
        spec["settings"]["clearance"] = float(_pick(rng, (0.0, 0.01, 0.05)))
    elif r < 0.09:
        spec["settings"]["elbow_side"] = _pick(rng, ("prefer", "off"))
    elif r < 0.11:
        spec["settings"]["check_hand"] = False
    if spec["settings"]:
        features.add("settings")
    if spec["duration"] is not None:
        features.add("duration")

    # the obstacles
    n_obstacles = int(rng.choice(6, p=[0.15, 0.35, 0.25, 0.14, 0.07, 0.04]))
    spec["obstacles"] = [_obstacle(rng, features, i) for i in range(n_obstacles)]
    for o in spec["obstacles"]:
        o["target"] = int(rng.integers(n_targets))
    spec["room"] = bool(rng.random() < 0.05)
    spec["floor"] = bool(rng.random() < 0.2)
    features |= {f for f in ("room", "floor") if spec[f]}
    if not n_obstacles and not spec["room"] and not spec["floor"]:
        features.add("no_obstacles")
    spec["obstacle_collection"] = bool(rng.random() < 0.08)
    if spec["obstacle_collection"]:
        features.add("obstacle_collection")
    if quick:
        spec["settings"].update(QUICK_SETTINGS)
        if rig["kind"] == "rigify":
            rig["kind"] = "metarig"
    # the body moving while the arm reaches (keys on the armature, or on the object that
    # carries it): from a stream of its own, so every other draw keeps its scene
    body = np.random.default_rng([seed, 1])
    spec["body_moves"] = None
    if body.random() < 0.03 and not spec["linked_armature"]:
        spec["body_moves"] = {"delta": _unit(body.normal(size=3)).tolist(),
                              "arm_lengths": float(body.uniform(0.1, 0.4)),
                              "spin_deg": float(body.uniform(-20, 20)) if body.random() < 0.5
                              else 0.0,
                              "frames": int(body.integers(20, 60))}
        features.add("body_moves")
    # every bone rotating in one Euler order, as a BVH import or a hand-made rig has it:
    # Blender then blends three angles between keys, not a quaternion (a stream of its own)
    euler = np.random.default_rng([seed, 2])
    spec["euler_bones"] = None
    if euler.random() < EULER_BONES_SHARE and not spec["linked_armature"]:
        spec["euler_bones"] = _pick(euler, ("XYZ", "XZY", "YXZ", "YZX", "ZXY", "ZYX"))
        features.add("euler_bones")
    # the synthetic rig's shape — rest pose, elbow, proportions, hand, bone rolls, rigid
    # parts — from a stream of its own, so every other draw keeps its scene
    if rig["kind"] == "synthetic" and shapes:
        rig["shape"] = _rig_shape(np.random.default_rng([seed, 3]), rig, features)
    spec["quick"] = quick
    spec["features"] = sorted(features)
    return spec


def _rig_shape(rng, rig: dict, features: set) -> dict:
    """A synthetic rig's shape (the keyword arguments of ``synthetic.humanoid`` and
    ``synthetic.shape``, plain data): the arm's rest pose (T, A, arms down), its elbow bend
    (0-25°, or the standard 30°) and the way it bends, the forearm over the upper arm
    (0.6-2.5, or the standard 0.86), the hand (one bone, a mitten, five fingers, or 2-4
    sibling palms with 1-3 finger bones each), its roll against the forearm (-90° to 90°),
    a bone roll convention, and rigid parts parented to bones instead of a skin. Every
    value is drawn whatever is kept, so the stream stays aligned."""
    pose = _pick(rng, ("A", "T", "down"), (5, 3, 2))
    bent = rng.random() < 0.6
    bend = float(rng.uniform(0.0, 25.0))
    turned = rng.random() < 0.35
    way = _unit(rng.normal(size=3)).tolist()
    proportioned = rng.random() < 0.4
    ratio = float(np.exp(rng.uniform(math.log(0.6), math.log(2.5))))
    hand = _pick(rng, ("bone", "mitten", "fingers", "palms"), (55, 15, 15, 15))
    palms, fingers = int(rng.integers(2, 5)), int(rng.integers(1, 4))
    rolled = rng.random() < 0.4
    hand_roll = float(rng.uniform(-90.0, 90.0))
    roll = _pick(rng, BONE_ROLLS, (2, 1, 1, 1, 1))
    rigid = rng.random() < 0.12
    if hand == "palms" and rig["decoy"] is not None:
        hand = "fingers"            # sibling palms take no decoy chain (synthetic.humanoid)
    rigid = rigid and rig["skin"] and rig["decoy"] is None   # a decoy is told by the skin
    shape = {"pose": pose, "elbow_bend_deg": bend if bent else None,
             "elbow_bend_dir": way if bent and turned else None,
             "forearm_ratio": ratio if proportioned else None,
             "hand": hand, "palms": palms if hand == "palms" else 0,
             "fingers": fingers if hand == "palms" else 1,
             "hand_roll_deg": hand_roll if rolled else 0.0,
             "roll": None if roll is None else list(roll), "rigid": bool(rigid)}
    features |= {f for f, on in (
        ("rig_t_pose", pose == "T"), ("rig_arms_down", pose == "down"),
        ("rig_straight_elbow", bent and bend < 5.0), ("rig_elbow_turned", bent and turned),
        ("rig_hand_roll", rolled), ("rig_bone_roll", roll is not None),
        ("rig_mitten", hand == "mitten"), ("rig_fingers", hand == "fingers"),
        ("rig_palms", hand == "palms"), ("rig_rigid", rigid),
        ("rig_long_forearm", proportioned and ratio > 1.5),
        ("rig_short_forearm", proportioned and ratio < 0.8)) if on}
    return shape


def rig_proportions(rig: dict):
    """The ``proportions`` dict of a synthetic rig's shape (``synthetic.shape``), or None
    for the standard one (a spec without a shape: the campaigns before it)."""
    import synthetic

    shape = rig.get("shape")
    if shape is None:
        return None
    return synthetic.shape(pose=shape["pose"], elbow_bend_deg=shape["elbow_bend_deg"],
                           elbow_bend_dir=shape["elbow_bend_dir"],
                           forearm_ratio=shape["forearm_ratio"])


# --- building the scene in Blender ---------------------------------------------------------

def _bpy():
    import bpy

    return bpy


def _matrix(m):
    from mathutils import Matrix

    return Matrix(np.asarray(m, dtype=float).tolist())


def _translation(p) -> np.ndarray:
    m = np.eye(4)
    m[:3, 3] = p
    return m


def stage_matrix(stage: dict) -> np.ndarray:
    """The world transform every placed object and the rig are put under: translate ·
    rotate · uniform scale · mirror."""
    m = np.eye(4)
    rot = np.eye(3) if stage["rotation"] is None else _quat_matrix(stage["rotation"])
    mirror = np.ones(3)
    if stage["mirror"] is not None:
        mirror[stage["mirror"]] = -1.0
    m[:3, :3] = rot @ np.diag(mirror) * stage["scale"]
    m[:3, 3] = np.asarray(stage["translate"], dtype=float) * stage["scale"]
    return m


_UNIT_BOX_VERTS = [(x, y, z) for x in (-0.5, 0.5) for y in (-0.5, 0.5) for z in (-0.5, 0.5)]
_UNIT_BOX_FACES = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
_UNIT_BOX_EDGES = [(0, 1), (1, 3), (3, 2), (2, 0), (4, 5), (5, 7), (7, 6), (6, 4), (0, 4), (1, 5),
                   (2, 6), (3, 7)]


def _geometry(o: dict):
    """(vertices, edges, faces) of an obstacle kind, in a unit cube round the origin."""
    kind = o["kind"]
    box_v, box_f = list(_UNIT_BOX_VERTS), list(_UNIT_BOX_FACES)
    if kind in ("box", "thin_wall", "zero_scale", "flat_scale", "linked_mesh"):
        return box_v, [], box_f
    if kind == "plane":
        return [(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)], [], [(0, 1, 2, 3)]
    if kind == "open_mesh":
        return box_v, [], [f for i, f in enumerate(box_f) if i not in o["drop_faces"]]
    if kind == "flipped_faces":
        return box_v, [], [tuple(reversed(f)) if i in o["flip_faces"] else f
                           for i, f in enumerate(box_f)]
    if kind == "tube":
        n = 8
        verts = [(0.5 * math.cos(2 * math.pi * k / n), 0.5 * math.sin(2 * math.pi * k / n), z)
                 for z in (-0.5, 0.5) for k in range(n)]
        return verts, [], [(k, (k + 1) % n, n + (k + 1) % n, n + k) for k in range(n)]
    if kind == "non_manifold":
        verts = box_v + [(0.5, 0.5, 1.2), (0.5, -0.5, 1.2),            # a fin on an edge
                         (-0.4, -0.4, 0), (0.4, -0.4, 0), (0.4, 0.4, 0), (-0.4, 0.4, 0),  # inner face
                         (0.9, 0.9, 0.9), (1.2, 1.2, 1.2), (-1.0, 0.0, 0.0)]  # loose edge, vertex
        faces = box_f + [(5, 7, 8, 9), (10, 11, 12, 13), box_f[0]]     # fin, inner, duplicate
        return verts, [(14, 15)], faces
    if kind == "collapsed_mesh":
        return [(0.0, 0.0, 0.0)] * 8, [], box_f
    if kind == "edges_only":
        return box_v, list(_UNIT_BOX_EDGES), []
    if kind == "empty_mesh":
        return [], [], []
    if kind == "dense_mesh":
        seg, rings = 16, 8
        verts = [(0.0, 0.0, -0.5)]
        for r in range(1, rings):
            phi = math.pi * r / rings - math.pi / 2
            verts += [(0.5 * math.cos(phi) * math.cos(2 * math.pi * k / seg),
                       0.5 * math.cos(phi) * math.sin(2 * math.pi * k / seg), 0.5 * math.sin(phi))
                      for k in range(seg)]
        verts.append((0.0, 0.0, 0.5))
        top = len(verts) - 1
        faces = [(0, 1 + (k + 1) % seg, 1 + k) for k in range(seg)]
        for r in range(rings - 2):
            a, b = 1 + r * seg, 1 + (r + 1) * seg
            faces += [(a + k, a + (k + 1) % seg, b + (k + 1) % seg, b + k) for k in range(seg)]
        last = 1 + (rings - 2) * seg
        faces += [(last + k, last + (k + 1) % seg, top) for k in range(seg)]
        return verts, [], faces
    if kind == "modifier":
        if o["modifier"] == "SOLIDIFY":
            return [(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)], [], [(0, 1, 2, 3)]
        if o["modifier"] == "MIRROR":
            return [(x * 0.4 + 0.3, y, z) for x, y, z in box_v], [], box_f
        return [(x * 0.4, y, z) for x, y, z in box_v], [], box_f
    raise ValueError(kind)


class Placement:
    """The rig's body frame at its base transform (before the stage): where body-frame
    points (arm lengths, x toward the reaching side) are in world space. Read with the rig
    adapter (:meth:`from_rig`) or, for a synthetic rig the adapter cannot read, from the
    synthetic construction itself (:meth:`from_synthetic`), so that the scene is still
    built and the bake's refusal is what is checked."""

    def __init__(self, armature, side, right, forward, up, origin, half, length, joints,
                 other_shoulder, hand_length, hand_radius, bones):
        s = 1.0 if side == "right" else -1.0
        self.side = side
        self.length = float(length)
        self.up, self.forward = _unit(up), _unit(forward)
        self.basis = np.column_stack([s * _unit(right), self.forward, self.up])
        self.origin = np.asarray(origin, dtype=float)
        self.half = float(half)
        self.joints = {k: np.asarray(v, dtype=float) for k, v in joints.items()}
        self.other_shoulder = np.asarray(other_shoulder, dtype=float)
        self.hand_length, self.hand_radius = float(hand_length), float(hand_radius)
        self.bones = bones          # role -> bone name, for targets carried by a bone
        mw = np.array(armature.matrix_world)
        ends = np.array([mw[:3, :3] @ np.array(p) + mw[:3, 3] for b in armature.data.bones
                         for p in (b.head_local, b.tail_local)])
        self.floor = float(((ends - self.origin) @ self.up).min())      # world units, along up

    @classmethod
    def from_rig(cls, armature, side):
        from reach_addon.blender import rig as rig_mod

        info = rig_mod.build(armature, side)
        other = "left" if side == "right" else "right"
        other_info = rig_mod.build(armature, other)
        f, b = info.frame, info.bones
        hips = armature.data.bones[b.chest]
        while hips.parent is not None:
            hips = hips.parent
        bones = {"chest": b.chest, "neck": b.neck or b.chest, "hips": hips.name,
                 "other_hand": b.arms[other].hand, "own_hand": b.arms[side].hand,
                 "own_forearm": b.arms[side].forearm}
        return cls(armature, side, f.right, f.forward, f.up, f.origin, f.shoulder_half_width,
                   info.arm.arm_length, info.joints_world, other_info.joints_world["shoulder"],
                   info.arm.hand_length, info.arm.hand_radius, bones)

    @classmethod
    def from_synthetic(cls, armature, rig: dict, side):
        import synthetic

        def world(p):
            return synthetic.to_world(p, facing=rig["facing"], lying=rig["lying"])

        tag, other = ("R", "L") if side == "right" else ("L", "R")
        proportions = rig_proportions(rig)
        joints = {k: world(v) for k, v in synthetic.arm_joints(tag, proportions).items()}
        names = synthetic.MAPS[rig["map"]]
        lengths = synthetic._proportions(proportions)["arm_lengths"]
        hand_length = 0.74 * lengths[1]
        palms = (rig.get("shape") or {}).get("palms", 0)

        def hand(t):    # sibling palms have no hand bone: the first palm carries a target
            return synthetic.palm_name(names, t, 1) if palms else names[f"hand_{t}"]

        bones = {"chest": names["chest"], "neck": names["neck"], "hips": names["hips"],
                 "other_hand": hand(other), "own_hand": hand(tag),
                 "own_forearm": names[f"forearm_{tag}"]}
        origin = world((0.0, 0.0, synthetic.SHOULDER_Z))
        return cls(armature, side, world((-1.0, 0, 0)), world((0, -1.0, 0)), world((0, 0, 1.0)),
                   origin, synthetic.SHOULDER_HALF_WIDTH, sum(lengths),
                   joints, world(synthetic.arm_joints(other, proportions)["shoulder"]), hand_length,
                   0.18 * hand_length, bones)

    def vector(self, v) -> np.ndarray:
        return self.length * (self.basis @ np.asarray(v, dtype=float))

    def body_point(self, name: str) -> np.ndarray:
        h, o, up, fw = self.half, self.origin, self.up, self.forward
        return {
            "shoulder": self.joints["shoulder"], "elbow": self.joints["elbow"],
            "wrist": self.joints["wrist"], "chest": o - 0.8 * h * up,
            "head": o + 1.2 * h * up + 0.1 * h * fw, "pelvis": o - 2.5 * h * up,
            "shoulder_other": self.other_shoulder,
            "chest_front": o - 0.8 * h * up + 0.68 * h * fw,
            "belly_front": o - 2.0 * h * up + 0.74 * h * fw,
        }[name]

    def target(self, t: dict) -> np.ndarray:
        return self.body_point(t["at"]) + self.vector(np.asarray(t["dir"]) * t["dist"])


def _make_library(path: Path):
    """A library file: collection FzLib holding FzLibBox (mesh FzLibMesh, a unit cube)."""
    bpy = _bpy()
    bpy.ops.wm.read_homefile(use_empty=True)
    mesh = bpy.data.meshes.new("FzLibMesh")
    mesh.from_pydata(_UNIT_BOX_VERTS, [], _UNIT_BOX_FACES)
    ob = bpy.data.objects.new("FzLibBox", mesh)
    coll = bpy.data.collections.new("FzLib")
    bpy.context.scene.collection.children.link(coll)
    coll.objects.link(ob)
    bpy.ops.wm.save_as_mainfile(filepath=str(path))


class RigCache:
    """The real rigs, loaded once per worker process and saved as plain .blend files
    (importing FBX or generating Rigify every scene would dominate the time)."""

    def __init__(self, folder: Path):
        self.folder = folder
        self.files: dict = {}

    def open(self, kind: str):
        bpy = _bpy()
        import rigs

        if kind not in self.files:
            arm = rigs.load(kind)
            rigs.rest_still(arm)
            path = self.folder / f"rig-{kind}.blend"
            bpy.ops.wm.save_as_mainfile(filepath=str(path))
            self.files[kind] = (path, arm.name)
        path, name = self.files[kind]
        bpy.ops.wm.open_mainfile(filepath=str(path), load_ui=False)
        return bpy.data.objects[name]


def _load_rig(spec, cache: RigCache, workdir: Path):
    """The rig of the scene, in an otherwise empty file; returns the armature."""
    bpy = _bpy()
    import synthetic

    rig = spec["rig"]
    if rig["kind"] == "synthetic":
        bpy.ops.wm.read_homefile(use_empty=True)
        shape = rig.get("shape") or {}
        hand = shape.get("hand", "bone")
        arm = synthetic.humanoid(synthetic.MAPS[rig["map"]], facing=rig["facing"],
                                 scale=rig["own_scale"], lying=rig["lying"],
                                 skin=rig["skin"] and not shape.get("rigid", False),
                                 decoy=rig["decoy"], clavicle=rig["clavicle"], twist=rig["twist"],
                                 name="FzRig", skin_radius=rig["skin_radius"],
                                 proportions=rig_proportions(rig),
                                 hand="bone" if hand == "palms" else hand,
                                 palms=shape.get("palms", 0), fingers=shape.get("fingers", 1),
                                 roll=shape.get("roll"),
                                 hand_roll_deg=shape.get("hand_roll_deg", 0.0),
                                 rigid=shape.get("rigid", False))
    else:
        arm = cache.open(rig["kind"])
    if spec["linked_armature"]:
        lib = workdir / "rig-library.blend"
        name = arm.name
        bpy.ops.wm.save_as_mainfile(filepath=str(lib))
        bpy.ops.wm.read_homefile(use_empty=True)
        with bpy.data.libraries.load(str(lib), link=True, relative=False) as (src, dst):
            dst.objects = list(src.objects)
        for ob in dst.objects:
            if ob is not None:
                bpy.context.scene.collection.objects.link(ob)
        arm = bpy.data.objects[name]
    bpy.context.view_layer.update()
    return arm


def _new_object(name, data, collection, parent=None, local=None):
    bpy = _bpy()
    ob = bpy.data.objects.new(name, data)
    collection.objects.link(ob)
    if parent is not None:
        ob.parent = parent
        ob.matrix_parent_inverse = _matrix(np.eye(4))
    if local is not None:
        ob.matrix_basis = _matrix(local)
    return ob


def _key_motion(ob, frame0: int, frames: int, delta, spin_deg: float):
    """Keys on ``ob``'s location (and its turn about its local z) from ``frame0`` to
    ``frame0 + frames``."""
    loc0 = np.array(ob.location)
    rot0 = np.array(ob.rotation_euler)
    ob.keyframe_insert("location", frame=frame0)
    ob.keyframe_insert("rotation_euler", frame=frame0)
    ob.location = (loc0 + np.asarray(delta)).tolist()
    ob.rotation_euler = (rot0 + np.array([0.0, 0.0, math.radians(spin_deg)])).tolist()
    ob.keyframe_insert("location", frame=frame0 + frames)
    ob.keyframe_insert("rotation_euler", frame=frame0 + frames)
    ob.location, ob.rotation_euler = loc0.tolist(), rot0.tolist()


def build(spec: dict, cache: RigCache, workdir: Path, library: Path) -> dict:
    """Build ``spec`` in Blender and save it as ``workdir/input.blend``. Returns the
    manifest the check needs: the armature's name, the obstacles that count (by the
    README's rules), which of them move, the targets, and the names a refusal should
    mention."""
    bpy = _bpy()
    from reach_addon.core import ReachError

    arm = _load_rig(spec, cache, workdir)
    scene = bpy.context.scene
    fs = spec["frame_current"]
    side = spec["side"]
    try:
        place = Placement.from_rig(arm, side)
    except ReachError:
        if spec["rig"]["kind"] != "synthetic":
            raise
        place = Placement.from_synthetic(arm, spec["rig"], side)
    L = place.length
    G = stage_matrix(spec["stage"])
    culprits: set = set()       # names a refusal may give
    must_refuse = False         # the input is bad: exit 2 expected
    root = scene.collection

    # the rig under the stage transform
    rig_roots = [ob for ob in scene.objects if ob.parent is None]
    rig_parent = None
    if spec["armature_parented"]:
        rig_parent = _new_object("FzRigParent", None, root)
        pm = G.copy()
        if spec["non_uniform"] and spec["non_uniform"]["on"] == "parent":
            pm[:3, :3] = pm[:3, :3] @ np.diag(spec["non_uniform"]["scale"])
            culprits |= {"FzRigParent", arm.name}
            must_refuse = True
        rig_parent.matrix_world = _matrix(pm)
    if not spec["linked_armature"]:
        for ob in rig_roots:
            base = np.array(ob.matrix_world)
            if rig_parent is not None:
                ob.parent = rig_parent
                ob.matrix_parent_inverse = _matrix(np.eye(4))
                ob.matrix_basis = _matrix(base)
            else:
                ob.matrix_world = _matrix(G @ base)
        if spec["non_uniform"] and spec["non_uniform"]["on"] == "armature":
            arm.scale = (np.array(arm.scale) * np.array(spec["non_uniform"]["scale"])).tolist()
            culprits.add(arm.name)
            must_refuse = True
    else:
        culprits.add(arm.name)
        must_refuse = True
    stage = _new_object("FzStage", None, root)
    stage.matrix_world = _matrix(G)
    bpy.context.view_layer.update()

    collections = {}

    def collection(name):
        if name not in collections:
            c = bpy.data.collections.new(name)
            root.children.link(c)
            collections[name] = c
        return collections[name]

    # the targets
    targets_w = []
    manifest_targets = []
    deferred_bone_targets = []
    for t in spec["targets"]:
        p = place.target(t)
        targets_w.append(p)
        parent = t["parent"]
        name = t["name"]
        ref = "end" if spec["task"] == "chase" else "start"
        if parent is None:
            ob = _new_object(name, None, root, stage, _translation(p))
        elif parent["kind"] == "moving":
            offset = place.vector([0.1, 0.0, 0.0])
            carrier = _new_object(f"FzCarrier{t['index']}", None, root, stage, _translation(p - offset))
            carrier.rotation_mode = "XYZ"
            _key_motion(carrier, fs, parent["frames"], place.vector(parent["delta"]),
                        parent["spin_deg"])
            ob = _new_object(name, None, root, carrier, _translation(offset))
        else:
            ob = _new_object(name, None, root)
            deferred_bone_targets.append((ob, parent["role"], p))
            ref = "end"
        ob.empty_display_type = "SPHERE"
        ob.empty_display_size = 0.02 * L
        manifest_targets.append({"name": ob.name, "ref": ref, "nan": t["nan"]})
        if t["nan"]:
            culprits.add(ob.name)
            must_refuse = True
        if parent is not None and parent["kind"] == "bone" and parent["role"].startswith("own"):
            culprits.add(ob.name)   # carried by the reaching arm: refused, naming it
        if spec["task"] == "chase" and (parent is None or parent["kind"] != "moving"):
            culprits.add(ob.name)   # nothing moves it: a chase is refused, naming it
    bpy.context.view_layer.update()
    for ob, role, p in deferred_bone_targets:
        name = place.bones[role]
        ob.parent = arm
        ob.parent_type = "BONE"
        ob.parent_bone = name
        bpy.context.view_layer.update()
        ob.matrix_world = _matrix(G @ _translation(p))
    bpy.context.view_layer.update()

    # the obstacles
    solids, movers = [], []
    nan_vertex = []             # still obstacles with a NaN vertex
    use_collection = spec["obstacle_collection"]
    linked = None
    wrist = place.joints["wrist"]
    hand_dir = wrist - place.joints["elbow"]
    hand_dir /= np.linalg.norm(hand_dir)
    for o in spec["obstacles"]:
        i = o["index"]
        name = f"Fz{o['kind'].title().replace('_', '')}{i}"
        tgt = targets_w[o["target"]]
        size = np.asarray(o["size"], dtype=float)
        rot = place.basis @ (np.eye(3) if o["rotation"] is None else _quat_matrix(o["rotation"]))
        if o["placement"] == "across":
            centre = wrist + o["t"] * (tgt - wrist) + place.vector(o["jitter"])
            path = tgt - wrist
            if o["face_path"] and np.linalg.norm(path) > 1e-6 * L:
                normal = path / np.linalg.norm(path)
                across = np.cross(normal, place.up)
                if np.linalg.norm(across) < 1e-6:
                    across = np.cross(normal, place.forward)
                across /= np.linalg.norm(across)
                rot = np.column_stack([across, np.cross(normal, across), normal])
        elif o["placement"] == "near_target":
            rot = place.basis
            centre = tgt - place.up * L * (0.06 + 0.5 * min(size[2], 0.3)) + place.vector(
                np.array(o["jitter"]) * [1, 1, 0])
        elif o["placement"] == "around":
            centre = place.joints["shoulder"] + place.vector(o["around"])
        else:   # under the hand: its top just below the wrist, touching the hand's capsule
            rot = place.basis
            size = size * [1, 1, 0.5]
            tip = wrist + hand_dir * place.hand_length
            low = min((wrist - place.origin) @ place.up, (tip - place.origin) @ place.up)
            top = low - 0.5 * place.hand_radius
            centre = 0.5 * (wrist + tip)
            centre = centre + place.up * (top - (centre - place.origin) @ place.up - 0.5 * size[2] * L)
        scale = size * L
        if o["kind"] == "zero_scale":
            scale = np.zeros(3)
        elif o["kind"] == "flat_scale":
            scale[2] = 0.0
        local = np.eye(4)
        local[:3, :3] = rot @ np.diag(scale)
        local[:3, 3] = centre

        vis = o["visibility"]
        if vis == "excluded_collection":
            coll = collection("FzExcluded")
        elif vis == "hidden_collection":
            coll = collection("FzHiddenCollection")
        elif use_collection and i % 2 == 0:
            coll = collection("FzObstacles")
        else:
            coll = root
        parent = stage
        if o["animated"] and o["animated"]["kind"] == "parent":
            parent = _new_object(f"FzMover{i}", None, root, stage, np.eye(4))
            parent.rotation_mode = "XYZ"
        if o["kind"] == "linked_instance":
            if linked is None:
                with bpy.data.libraries.load(str(library), link=True, relative=True) as (src, dst):
                    dst.collections = ["FzLib"]
                    dst.meshes = ["FzLibMesh"]
                linked = bpy.data.collections["FzLib"]
            ob = _new_object(name, None, coll, parent, local)
            ob.instance_type = "COLLECTION"
            ob.instance_collection = linked
        elif o["kind"] == "linked_mesh":
            if linked is None:
                with bpy.data.libraries.load(str(library), link=True, relative=True) as (src, dst):
                    dst.collections = ["FzLib"]
                    dst.meshes = ["FzLibMesh"]
                linked = bpy.data.collections["FzLib"]
            ob = _new_object(name, bpy.data.meshes["FzLibMesh"], coll, parent, local)
        else:
            verts, edges, faces = _geometry(o)
            mesh = bpy.data.meshes.new(name)
            mesh.from_pydata(verts, edges, faces)
            if o["nan"] == "vertex":
                mesh.vertices[0].co = (float("nan"), 0.0, 0.0)
            ob = _new_object(name, mesh, coll, parent, local)
            if o["kind"] == "modifier":
                mod = ob.modifiers.new("FzModifier", o["modifier"])
                if o["modifier"] == "SOLIDIFY":
                    mod.thickness = 0.05
                elif o["modifier"] == "ARRAY":
                    mod.count = 3
                elif o["modifier"] == "SUBSURF":
                    mod.levels = 1
        if o["animated"]:
            a = o["animated"]
            mover = parent if a["kind"] == "parent" else ob
            if a["kind"] == "keys":
                ob.rotation_mode = "XYZ"
            _key_motion(mover, fs, a["frames"], place.vector(a["delta"]), a["spin_deg"])
        if vis == "hidden":
            ob.hide_set(True)
        elif vis == "disabled":
            ob.hide_viewport = True
        elif vis == "render_hidden":
            ob.hide_render = True
        counts = vis in ("visible", "render_hidden") and (not use_collection or coll.name == "FzObstacles")
        if o["nan"] in ("nan", "inf"):
            value = float("nan") if o["nan"] == "nan" else float("inf")
            ob.location = (value, 0.0, 0.0)
        keyed = o["animated"] is not None and o["animated"]["kind"] == "keys"
        if keyed and o["nan"] in ("nan", "inf"):
            pass    # its location is animated: the keys set it on every frame, NaN or not
        elif counts and o["nan"] == "vertex" and o["kind"] not in ("edges_only", "empty_mesh"):
            # A Plan does not read an object whose box lies beyond the arm's reach (the
            # README's "Only what the arm can reach"; Blender's box skips the NaN vertex).
            # Within 1.5 arm lengths of the shoulder it is surely read, hence refused (see
            # below); farther, the bake may go on, and then the check holds the arm to its
            # finite faces (solid_triangles drops the NaN ones). A mesh with no faces is no
            # obstacle at all (seeds 4456, 8867: bare edges): nothing is read, nothing
            # refused.
            culprits.add(ob.name)
            if not o["animated"]:
                nan_vertex.append(ob)
        elif counts and o["nan"] and o["kind"] not in ("edges_only", "empty_mesh"):
            culprits.add(ob.name)
            must_refuse = True
        if counts and o["kind"] not in NO_SURFACE and o["nan"] in (None, "vertex"):
            solids.append(ob.name)
            if o["animated"]:
                movers.append(ob.name)
    if "FzHiddenCollection" in collections:
        collections["FzHiddenCollection"].hide_viewport = True
    if "FzExcluded" in collections:
        bpy.context.view_layer.layer_collection.children["FzExcluded"].exclude = True
    if use_collection:
        coll = collection("FzObstacles")
        culprits.add(coll.name)
    if spec["floor"] or spec["room"]:
        up_level = place.floor
        if spec["floor"]:
            local = np.eye(4)
            local[:3, :3] = place.basis @ np.diag([8 * L, 8 * L, 1.0])
            local[:3, 3] = place.origin + place.up * up_level
            mesh = bpy.data.meshes.new("FzFloor")
            mesh.from_pydata([(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)], [],
                             [(0, 1, 2, 3)])
            ob = _new_object("FzFloor", mesh, root, stage, local)
            if not use_collection:
                solids.append(ob.name)
        if spec["room"]:
            height = place.length * 1.5 - up_level
            local = np.eye(4)
            local[:3, :3] = place.basis @ np.diag([5 * L, 5 * L, height + 0.4 * L])
            local[:3, 3] = place.origin + place.up * (up_level - 0.2 * L + 0.5 * (height + 0.4 * L))
            mesh = bpy.data.meshes.new("FzRoom")
            mesh.from_pydata(_UNIT_BOX_VERTS, [], _UNIT_BOX_FACES)
            ob = _new_object("FzRoom", mesh, root, stage, local)
            if not use_collection:
                solids.append(ob.name)

    if spec.get("euler_bones"):
        for pb in arm.pose.bones:          # Blender converts the pose to the new order
            pb.rotation_mode = spec["euler_bones"]
    moves = spec.get("body_moves")
    mover = None
    if moves:
        # the armature (or what carries it) walks off while the arm reaches: the bake
        # must refuse naming it, fail with a reason, or be verified on target as it is
        mover = rig_parent if rig_parent is not None else arm
        _key_motion(mover, fs, moves["frames"],
                    place.vector(moves["delta"]) * moves["arm_lengths"], moves["spin_deg"])
    if spec["new_action"]:
        root_bone = next(b for b in arm.pose.bones if b.parent is None)
        root_bone.keyframe_insert("location", frame=fs)
    if spec["armature_nan"] and not spec["linked_armature"]:
        value = float("nan") if spec["armature_nan"] == "nan" else float("inf")
        arm.location = (value, arm.location[1], arm.location[2])
        # where the armature's own location is keyed (body_moves), its curves put a finite
        # location back on every frame: the input is not bad then
        if mover is not arm:
            culprits.add(arm.name)
            must_refuse = True
    for t, m in zip(spec["targets"], manifest_targets):
        if t["nan"]:
            ob = bpy.data.objects[m["name"]]
            ob.location = (float("nan") if t["nan"] == "nan" else float("inf"), 0.0, 0.0)
    scene.frame_current = fs
    bpy.context.view_layer.update()
    if nan_vertex and _near_shoulder(nan_vertex, G, place, 1.5):
        must_refuse = True
    scene.frame_start = min(fs, scene.frame_start)
    scene.frame_end = max(scene.frame_end, fs + 60)
    bpy.context.view_layer.update()
    path = workdir / "input.blend"
    bpy.ops.wm.save_as_mainfile(filepath=str(path), relative_remap=True)
    files = [path] + ([library] if linked is not None else [])
    if spec["linked_armature"]:
        files.append(workdir / "rig-library.blend")
    return {"input": str(path), "files": [str(f) for f in files], "armature": arm.name,
            "targets": manifest_targets, "solids": solids, "movers": movers,
            "names": sorted({ob.name for ob in bpy.data.objects} | set(collections)),
            "culprits": sorted(culprits), "must_refuse": must_refuse,
            "arm_length": L * spec["stage"]["scale"]}


# --- baking it as a user does, and checking the outcome ------------------------------------

def bake_argv(spec: dict, manifest: dict, output: Path, report: Path) -> list:
    """The command line of the scene: ``reach bake INPUT --armature ... --output ...``."""
    argv = ["bake", manifest["input"], "--armature", manifest["armature"]]
    for t in manifest["targets"]:
        argv += ["--target", t["name"]]
    argv += ["--task", spec["task"], "--arm", spec["arm"]]
    if spec["frame_start_flag"] is not None:
        argv += ["--frame-start", str(spec["frame_start_flag"])]
    if spec["bake_closest"]:
        argv.append("--bake-closest")
    if spec["new_action"]:
        argv.append("--new-action")
    if spec["no_chest_rotation"]:
        argv.append("--no-chest-rotation")
    if spec["duration"] is not None:
        argv += ["--duration", f"{spec['duration']:.3f}"]
    if spec["obstacle_collection"]:
        argv += ["--obstacles", "FzObstacles"]
    for name, value in sorted(spec["settings"].items()):
        flag = "--" + name.replace("_", "-")
        argv += [flag] if value is True else [f"--no-{name.replace('_', '-')}"] \
            if value is False else [flag, str(value)]
    return argv + ["--output", str(output), "--report", str(report)]


def run_cli(argv: list) -> dict:
    """``reach_addon.cli.main(argv)`` in this process, its output captured; an exception
    that leaves it is caught here and kept with its traceback."""
    import contextlib
    import io
    import warnings

    from reach_addon import cli

    out, err = io.StringIO(), io.StringIO()
    exc = None
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), \
            warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")     # the same warnings on every run, kept apart
        try:
            rc = cli.main(argv)
        except Exception:   # noqa: BLE001  (every escaping exception is a finding)
            rc, exc = None, traceback.format_exc()
    notes = sorted({f"{Path(w.filename).name}:{w.lineno}: {w.category.__name__}: {w.message}"
                    for w in caught})
    return {"rc": rc, "stdout": out.getvalue(), "stderr": err.getvalue(), "exception": exc,
            "warnings": notes}


def digest(path) -> str:
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def _fcurves(action):
    if hasattr(action, "layers") and len(action.layers):
        return [fc for layer in action.layers for strip in layer.strips
                for bag in strip.channelbags for fc in bag.fcurves]
    return list(getattr(action, "fcurves", []))


def keyed_values() -> list:
    """Every key of every action of the open file, as raw bytes: (action, data path,
    index, bytes of the float32 frames, values and handles and the interpolations)."""
    bpy = _bpy()
    out = []
    for action in sorted(bpy.data.actions, key=lambda a: a.name):
        for fc in _fcurves(action):
            pts = fc.keyframe_points
            n = len(pts)
            parts = []
            for attr in ("co", "handle_left", "handle_right"):
                a = np.empty(2 * n, dtype=np.float32)
                pts.foreach_get(attr, a)
                parts.append(a.tobytes())
            interp = np.empty(n, dtype=np.int32)
            pts.foreach_get("interpolation", interp)
            parts.append(interp.tobytes())
            out.append((action.name, fc.data_path, fc.array_index, b"".join(parts)))
    return out


def _mesh_triangles(mesh, matrix) -> np.ndarray:
    mesh.calc_loop_triangles()
    n_v, n_t = len(mesh.vertices), len(mesh.loop_triangles)
    if n_t == 0:
        return np.zeros((0, 3, 3))
    co = np.empty(n_v * 3, dtype=np.float32)
    mesh.vertices.foreach_get("co", co)
    idx = np.empty(n_t * 3, dtype=np.int32)
    mesh.loop_triangles.foreach_get("vertices", idx)
    m = np.asarray(matrix, dtype=float)
    world = co.reshape(-1, 3).astype(float) @ m[:3, :3].T + m[:3, 3]
    return world[idx.reshape(-1, 3)]


def _near_shoulder(objects, G, place, reach: float) -> bool:
    """Whether the box of any object's finite vertices (world, evaluated now) comes within
    ``reach`` arm lengths of the reaching shoulder in its start pose. Any point within
    1.5 arm lengths of the shoulder lies inside the arm's reach sphere (its radius is at
    least the shoulder's distance from the spine plus arm, hand and half an arm), so such
    an object is read by a Plan."""
    bpy = _bpy()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    shoulder = G[:3, :3] @ place.joints["shoulder"] + G[:3, 3]
    length = place.length * np.linalg.norm(G[:3, 0])
    for ob in objects:
        ev = ob.evaluated_get(depsgraph)
        co = np.array([v.co for v in ev.data.vertices], dtype=float).reshape(-1, 3)
        co = co[np.isfinite(co).all(axis=1)]
        if not len(co):
            continue
        m = np.array(ev.matrix_world)
        world = co @ m[:3, :3].T + m[:3, 3]
        lo, hi = world.min(0), world.max(0)
        if np.linalg.norm(np.maximum(0.0, np.maximum(lo - shoulder, shoulder - hi))) <= reach * length:
            return True
    return False


def solid_triangles(names, min_area: float) -> np.ndarray:
    """World triangles (T, 3, 3) of the named obstacles as Blender evaluates them now
    (modifiers applied; a collection instance's objects under its instancer); triangles
    of less than ``min_area`` are left out (no surface to touch)."""
    bpy = _bpy()
    depsgraph = bpy.context.evaluated_depsgraph_get()
    parts = [np.zeros((0, 3, 3))]
    for name in names:
        ob = bpy.data.objects[name]
        if ob.instance_type == "COLLECTION" and ob.instance_collection is not None:
            coll = ob.instance_collection
            base = np.array(ob.evaluated_get(depsgraph).matrix_world) @ _translation(
                -np.array(coll.instance_offset))
            for inner in coll.all_objects:
                if inner.type == "MESH":
                    parts.append(_mesh_triangles(inner.data, base @ np.array(inner.matrix_world)))
            continue
        ev = ob.evaluated_get(depsgraph)
        mesh = ev.to_mesh()
        try:
            parts.append(_mesh_triangles(mesh, np.array(ev.matrix_world)))
        finally:
            ev.to_mesh_clear()
    tris = np.concatenate(parts)
    area = 0.5 * np.linalg.norm(np.cross(tris[:, 1] - tris[:, 0], tris[:, 2] - tris[:, 0]), axis=1)
    return tris[area > min_area]


class ArmReader:
    """The reaching arm's five joints at the current evaluation: each joint is carried by
    its bone (read from the rig model in the start pose: sternum by the clavicle, or the
    chest without one; the hand's far end by the hand)."""

    def __init__(self, armature, info):
        from reach_addon.blender import rig as rig_mod

        bones = info.bones.arms[info.side]
        self.names = (bones.clavicle or info.bones.chest, bones.upper_arm, bones.forearm,
                      bones.hand)
        sternum = info.arm.to_world_points(np.asarray(info.arm.sternum, dtype=float))
        group = getattr(info, "hand_bones", None) or None
        axis, _l, _s = rig_mod.hand_shape(armature, bones.hand, info.arm.forearm_length,
                                          **({"group": group} if group else {}))
        mats = self._matrices(armature)
        tip = mats[3][:3, 3] + axis * info.arm.hand_length
        self.sternum_local = np.linalg.solve(mats[0], np.append(sternum, 1.0))
        self.tip_local = np.linalg.solve(mats[3], np.append(tip, 1.0))

    def _matrices(self, armature):
        mw = np.array(armature.matrix_world)
        return [mw @ np.array(armature.pose.bones[n].matrix) for n in self.names]

    def joints(self, armature) -> np.ndarray:
        anchor, upper, fore, hand = self._matrices(armature)
        return np.array([(anchor @ self.sternum_local)[:3], upper[:3, 3], fore[:3, 3],
                         hand[:3, 3], (hand @ self.tip_local)[:3]])


def verify(manifest: dict, report: dict, output: Path, subframes: int) -> list:
    """The independent check of every successful, baked task of ``report`` in ``output``;
    returns the problems found: [(category, one line)]."""
    bpy = _bpy()
    from reach_addon.blender import rig as rig_mod

    from verification.clearance import independent_check

    tasks = [t for t in report["tasks"] if t["success"] and t["bones_keyed"]]
    if not tasks:
        return []
    first = min(t["frame_start"] for t in report["tasks"])
    # the rig model (radii, the hand), from the input as the bake read it
    bpy.ops.wm.open_mainfile(filepath=manifest["input"], load_ui=False)
    scene = bpy.context.scene
    scene.frame_set(first)
    arm = bpy.data.objects[manifest["armature"]]
    info = rig_mod.build(arm, report["arm"])
    reader = ArmReader(arm, info)
    length = info.arm.arm_length
    start_positions = {t["name"]: np.array(bpy.data.objects[t["name"]].matrix_world.translation)
                       for t in manifest["targets"]}
    refs = {t["name"]: t["ref"] for t in manifest["targets"]}

    bpy.ops.wm.open_mainfile(filepath=str(output), load_ui=False)
    scene = bpy.context.scene
    arm = bpy.data.objects[manifest["armature"]]
    movers = set(manifest["movers"])
    min_area = 1e-10 * length * length
    static = None
    problems = []
    horizon = 0.05 * length
    tolerance = (0.005 + 1e-4) * length
    hand = bool(report.get("settings", {}).get("check_hand", True))   # off: the user's choice
    for task in tasks:
        fa, fb = int(task["frame_start"]), int(task["frame_end"])
        instants = [(f, k / (subframes + 1)) for f in range(fa, fb) for k in range(subframes + 1)]
        instants.append((fb, 0.0))
        leaving = True           # a start in contact may stay in contact only while leaving it
        touching = []            # (instant, part, depth) after the first clear instant
        for f, sub in instants:
            scene.frame_set(f, subframe=sub)
            if static is None:
                static = solid_triangles([n for n in manifest["solids"] if n not in movers], min_area)
            tris = static
            if movers:
                tris = np.concatenate([static, solid_triangles(sorted(movers), min_area)])
            joints = reader.joints(arm)
            hits, arm_hits, least = independent_check(info.arm, joints[None], tris, hand, horizon)
            if not hits:
                leaving = False
            elif not leaving:
                touching.append((f + sub, "arm" if arm_hits else "hand", -least / length))
        if touching:
            at, part, depth = max(touching, key=lambda x: x[2])
            problems.append(("success_but_collides",
                             f"'{task['target']}': {len(touching)} instant(s) from frame "
                             f"{touching[0][0]:.2f} to {touching[-1][0]:.2f} touching, the "
                             f"deepest the {part} {depth:.4f} arm lengths in at frame {at:.2f}"))
        scene.frame_set(fb)
        wrist = reader.joints(arm)[3]
        name = task["target"]
        goal = (start_positions[name] if refs.get(name, "start") == "start"
                else np.array(bpy.data.objects[name].matrix_world.translation))
        gap = float(np.linalg.norm(wrist - goal))
        if not gap <= tolerance:
            problems.append(("success_off_target",
                             f"'{name}': the wrist is {gap / length:.4f} arm lengths from the "
                             f"target at frame {fb}"))
    return problems


_REPORT_KEYS = ("target", "arm", "success", "reason", "message", "frame_start", "frame_end",
                "bones_keyed", "nodes_searched", "nodes_in_solution", "frames")


def _essentials(run: dict):
    report = run.get("report")
    tasks = None
    if report is not None:
        tasks = [{k: t.get(k) for k in _REPORT_KEYS} for t in report["tasks"]]
    return run["rc"], run["stderr"].strip(), tasks


def _refusal(stderr: str) -> str:
    lines = [line for line in stderr.strip().splitlines() if line.startswith("reach: ")]
    return lines[-1][len("reach: "):] if lines else ""


def classify(spec: dict, manifest: dict, runs: list, changed: list, keys: list,
             problems: list) -> tuple:
    """(category, one line) of a scene from its two runs; the worst finding wins."""
    from reach_addon.core import REASONS

    for run in runs:
        if run["exception"]:
            last = run["exception"].strip().splitlines()[-1]
            return "escaped_exception", last
    if changed:
        return "input_changed", f"{', '.join(Path(c).name for c in changed)} changed"
    first, second = _essentials(runs[0]), _essentials(runs[1])
    if first != second:
        what = "exit status" if first[0] != second[0] else "message" if first[1] != second[1] \
            else "report"
        if what == "report" and first[2] and second[2] and len(first[2]) == len(second[2]):
            what = next(f"report '{k}' ({a[k]!r} vs {b[k]!r})" for a, b in zip(first[2], second[2])
                        for k in a if a[k] != b[k])
        return "nondeterministic", f"the two bakes ended differently: {what}"
    if keys[0] != keys[1]:
        differ = next((a[1], a[2]) for a, b in zip(keys[0], keys[1]) if a != b) \
            if len(keys[0]) == len(keys[1]) else ("count", len(keys[0]) - len(keys[1]))
        return "nondeterministic", f"the two bakes keyed different values ({differ[0]}[{differ[1]}])"
    for category in ("success_but_collides", "success_off_target"):
        for c, line in problems:
            if c == category:
                return c, line
    rc = runs[0]["rc"]
    if rc == 2:
        message = _refusal(runs[0]["stderr"])
        if not message:
            return "unclear_failure", "exit 2 without a message"
        # The message names an object of the scene; where the scene has a fault of its
        # own, the object at fault (or the armature, whose problems are found first).
        wanted = manifest["culprits"] + [manifest["armature"]] if manifest["must_refuse"] \
            else manifest["names"]
        if not any(c in message for c in wanted):
            return "unclear_failure", f"refused without naming {wanted}: {message}"
        return "failure_with_reason", f"bad_input: {message}"
    report = runs[0]["report"]
    if rc not in (0, 1) or report is None:
        return "unclear_failure", f"exit status {rc}"
    failed = [t for t in report["tasks"] if not t["success"]]
    for t in failed:
        if t["reason"] not in REASONS or not t["message"]:
            return "unclear_failure", f"'{t['target']}' failed with reason {t['reason']!r}"
    if (rc == 0) != (not failed):
        return "unclear_failure", f"exit status {rc} with {len(failed)} failed task(s)"
    if manifest["must_refuse"]:
        return "unclear_failure", f"bad input accepted (expected a refusal naming {manifest['culprits']})"
    if failed:
        t = failed[0]
        return "failure_with_reason", f"{t['reason']}: {t['message']}"
    return "success_verified", f"{len(report['tasks'])} task(s) reached and verified"


def cross_check(spec: dict, manifest: dict, report: dict, budget_s: float) -> list:
    """Every refusal of ``report`` (the first bake's) cross-checked on the scene's input
    file by :func:`verification.refusal.check_report`: OMPL's search where a goal region
    exists (``budget_s`` seconds; on a quick scene also at most the scene's own sampling
    budget of states, the budget its starved planner had), the skin for a start in
    collision. Returns the verdicts as plain data (one per failed task)."""
    bpy = _bpy()
    from verification import refusal

    bpy.ops.wm.open_mainfile(filepath=manifest["input"], load_ui=False)
    max_states = spec["settings"].get("sampling_budget") if spec.get("quick") else None
    verdicts = refusal.check_report(
        bpy.context, report, spec["task"], "FzObstacles" if spec["obstacle_collection"] else None,
        budget_s=budget_s, max_states=max_states, seed=spec["seed"])
    return [v.to_dict() for v in verdicts]


def run_scene(seed: int, scene_dir: Path, cache: RigCache, library: Path,
              subframes: int = SUBFRAMES, quick: bool = False,
              cross_check_s: float = CROSS_CHECK_BUDGET_S, shapes: bool = True) -> dict:
    """Generate, build, bake twice and check one scene, its refusals cross-checked
    (:func:`cross_check`, OMPL given ``cross_check_s`` seconds each; 0 skips it); returns
    its result (JSON). ``quick``, ``shapes``: as :func:`generate` takes them."""
    bpy = _bpy()
    t0 = time.perf_counter()
    spec = generate(seed, quick, shapes)
    result = {"seed": int(seed), "features": spec["features"], "task": spec["task"],
              "rig": spec["rig"]["kind"] if spec["rig"]["kind"] != "synthetic"
              else f"synthetic/{spec['rig']['map']}"}
    for p in scene_dir.glob("*"):
        if p.name != library.name and p.suffix in (".blend", ".blend1", ".json"):
            p.unlink()
    try:
        manifest = build(spec, cache, scene_dir, library)
    except Exception:   # noqa: BLE001
        tb = traceback.format_exc()
        result.update(category="generator_error", detail=tb.strip().splitlines()[-1], traceback=tb,
                      time_s=time.perf_counter() - t0)
        return result
    timings = {"build": time.perf_counter() - t0}
    before = {f: digest(f) for f in manifest["files"]}
    runs = []
    for k in (1, 2):
        output, report = scene_dir / f"output{k}.blend", scene_dir / f"report{k}.json"
        run = run_cli(bake_argv(spec, manifest, output, report))
        run["report"] = json.loads(report.read_text()) if report.exists() else None
        run["output"] = output
        runs.append(run)
        timings[f"bake{k}"] = time.perf_counter() - t0 - sum(timings.values())
    changed = [f for f, h in before.items() if not Path(f).exists() or digest(f) != h]
    keys, problems = [[], []], []
    try:
        if all(r["exception"] is None for r in runs):
            for k, run in enumerate(runs):
                if run["output"].exists():
                    bpy.ops.wm.open_mainfile(filepath=str(run["output"]), load_ui=False)
                    keys[k] = keyed_values()
            timings["keys"] = time.perf_counter() - t0 - sum(timings.values())
            if runs[1]["report"] is not None and runs[1]["rc"] in (0, 1):
                problems = verify(manifest, runs[1]["report"], runs[1]["output"], subframes)
        category, detail = classify(spec, manifest, runs, changed, keys, problems)
        timings["check"] = time.perf_counter() - t0 - sum(timings.values())
        if category == "failure_with_reason" and runs[0]["rc"] == 1 and cross_check_s > 0:
            checks = cross_check(spec, manifest, runs[0]["report"], cross_check_s)
            result["cross_check"] = checks
            false = [c for c in checks if c["status"] == "false_refusal"]
            if false:
                c = false[0]
                category, detail = "false_refusal", f"'{c['target']}' {c['reason']}: {c['detail']}"
            timings["cross_check"] = time.perf_counter() - t0 - sum(timings.values())
    except Exception:   # noqa: BLE001
        tb = traceback.format_exc()
        category, detail = "generator_error", "checking: " + tb.strip().splitlines()[-1]
        result["traceback"] = tb
    if category == "escaped_exception":
        result["traceback"] = next(r["exception"] for r in runs if r["exception"])
    timings.setdefault("check", time.perf_counter() - t0 - sum(timings.values()))
    result["timings"] = {k: round(v, 3) for k, v in timings.items()}
    if runs[0]["warnings"]:
        result["warnings"] = runs[0]["warnings"]
    result.update(category=category, detail=detail, exit_status=runs[0]["rc"],
                  time_s=round(time.perf_counter() - t0, 3))
    if runs[0]["report"] is not None:
        result["reasons"] = [t["reason"] for t in runs[0]["report"]["tasks"]]
    return result


# --- workers and the campaign ---------------------------------------------------------------

def worker(seeds: list, results: Path, subframes: int, keep: Path | None = None,
           quick: bool = False, cross_check_s: float = CROSS_CHECK_BUDGET_S,
           shapes: bool = True) -> None:
    """Run ``seeds`` one after another in this process, appending to ``results`` a line
    ``{"seed": s, "event": "start"}`` before each scene and its result after it."""
    os.environ["BLENDER_USER_RESOURCES"] = tempfile.mkdtemp(prefix="reach-fuzz-user-")
    sys.path.insert(0, str(ROOT / "tests" / "blender"))
    import bpy  # noqa: F401  (mathutils for the core)

    from reach_addon import ensure_registered

    ensure_registered()
    work = Path(tempfile.mkdtemp(prefix="reach-fuzz-"))
    try:
        scene_dir = keep if keep is not None else work / "scene"
        scene_dir.mkdir(parents=True, exist_ok=True)
        library = scene_dir / "library.blend"
        _make_library(library)
        cache = RigCache(work)
        with open(results, "a", encoding="utf-8") as out:
            for seed in seeds:
                out.write(json.dumps({"seed": int(seed), "event": "start"}) + "\n")
                out.flush()
                result = run_scene(int(seed), scene_dir, cache, library, subframes, quick,
                                   cross_check_s, shapes)
                out.write(json.dumps(result) + "\n")
                out.flush()
    finally:
        if keep is None:
            shutil.rmtree(work, ignore_errors=True)


def _worker_command(seeds: list, results: Path, subframes: int, quick: bool,
                    cross_check_s: float = CROSS_CHECK_BUDGET_S, shapes: bool = True) -> list:
    return [sys.executable, str(Path(__file__).resolve()), "--worker", "--results", str(results),
            "--subframes", str(subframes), "--seeds", ",".join(str(s) for s in seeds),
            "--cross-check-budget", repr(float(cross_check_s))] + \
        (["--quick"] if quick else []) + ([] if shapes else ["--standard-rigs"])


def _read_results(path: Path) -> tuple:
    """(results by seed, the last seed started without a result) of a worker's file."""
    done, started = {}, None
    if path.exists():
        for line in path.read_text(encoding="utf-8").splitlines():
            try:
                rec = json.loads(line)
            except json.JSONDecodeError:
                continue        # a line being written
            if rec.get("event") == "start":
                started = rec["seed"]
            else:
                done[rec["seed"]] = rec
    return done, (started if started is not None and started not in done else None)


def run_campaign(seeds, jobs: int = 2, subframes: int = SUBFRAMES, timeout_s: float = 600.0,
                 progress=None, quick: bool = False,
                 cross_check_s: float = CROSS_CHECK_BUDGET_S, shapes: bool = True) -> list:
    """Run ``seeds`` on ``jobs`` worker processes, each taking a contiguous range; returns
    the results in seed order. A worker that dies or stalls past ``timeout_s`` on one
    scene gives that seed ``escaped_exception`` or ``timeout`` and is restarted on the
    seeds after it. ``cross_check_s``: OMPL's seconds per refusal of the cross-check (0:
    none); ``quick``, ``shapes``: as :func:`generate` takes them."""
    seeds = [int(s) for s in seeds]
    jobs = max(1, min(jobs, len(seeds)))
    bounds = np.linspace(0, len(seeds), jobs + 1).round().astype(int)
    queues = [seeds[a:b] for a, b in zip(bounds[:-1], bounds[1:])]
    tmp = Path(tempfile.mkdtemp(prefix="reach-fuzz-runs-"))
    results: dict = {}
    workers = {}
    t_start = time.monotonic()

    def launch(k, queue):
        path = tmp / f"worker-{k}-{len(queue)}-{queue[0]}.jsonl"
        log = open(tmp / f"worker-{k}.log", "ab")
        proc = subprocess.Popen(_worker_command(queue, path, subframes, quick, cross_check_s,
                                                shapes),
                                cwd=ROOT,
                                stdout=subprocess.DEVNULL, stderr=log, start_new_session=True)
        workers[k] = {"proc": proc, "path": path, "queue": queue, "log": log,
                      "seen": 0, "last": time.monotonic(), "started": None}

    try:
        for k, q in enumerate(queues):
            if q:
                launch(k, q)
        while workers:
            time.sleep(0.5)
            for k in list(workers):
                w = workers[k]
                done, pending = _read_results(w["path"])
                results.update(done)
                if len(done) != w["seen"] or pending != w["started"]:
                    w["seen"], w["started"], w["last"] = len(done), pending, time.monotonic()
                rc = w["proc"].poll()
                stalled = rc is None and time.monotonic() - w["last"] > timeout_s
                if rc is None and not stalled:
                    continue
                if stalled:
                    os.killpg(w["proc"].pid, 9)
                    w["proc"].wait()
                w["log"].close()
                rest = [s for s in w["queue"] if s not in results]
                del workers[k]
                if rest:
                    lost = pending if pending is not None else rest[0]
                    tail = (tmp / f"worker-{k}.log").read_text(errors="replace").strip().splitlines()
                    why = (f"no result within {timeout_s:.0f} s" if stalled else
                           f"the process died (status {rc}): " + (tail[-1] if tail else ""))
                    spec = generate(lost, quick, shapes)
                    results[lost] = {"seed": lost, "features": spec["features"], "task": spec["task"],
                                     "rig": spec["rig"]["kind"],
                                     "category": "timeout" if stalled else "escaped_exception",
                                     "detail": why, "exit_status": None, "time_s": None}
                    rest = [s for s in rest if s != lost]
                    if rest:
                        launch(k, rest)
            if progress is not None:
                progress(len(results), len(seeds), time.monotonic() - t_start)
    finally:
        for w in workers.values():
            try:
                os.killpg(w["proc"].pid, 9)
            except ProcessLookupError:
                pass
        shutil.rmtree(tmp, ignore_errors=True)
    return [results[s] for s in seeds if s in results]


def _reason_key(result: dict) -> str:
    """A failure's reason without the names and numbers of its scene: the reason code, or
    the refusal's words."""
    detail = result["detail"]
    if detail.startswith("bad_input: "):
        # A name is quoted; it may hold quotes itself ('Cup''), so it ends at the quote
        # that a space, a punctuation mark or the end of the line follows.
        words = re.sub(r"(?<!\w)'.*?'(?=[\s;,.:)]|$)", "'…'", detail[len("bad_input: "):])
        words = re.sub(r"-?\d+(\.\d+)?(e-?\d+)?", "#", words)
        return "bad_input: " + words.split(";")[0]
    return detail.split(":")[0]


def cross_check_summary(results: list) -> dict:
    """The cross-check's part of fuzz.json: ``refusals_cross_checked`` (refused targets the
    cross-check decided: confirmed or contradicted), ``false_refusals`` (contradicted),
    ``refusals_not_decided`` (inconclusive or unchecked), ``cross_check_seconds`` (the
    cross-check's wall time over every scene, rebuilding the problem included), and per
    reason the counts of each
    verdict with the check's median and largest time (seconds), what decided them
    (``by_method``: ``ik`` no valid goal state, ``ompl``, ``skin``, ``bones``) and an
    example seed of each verdict;
    ``false_refusal_list`` gives each contradicted refusal (seed, target, reason, why)."""
    from verification.refusal import CONFIRMED, FALSE_REFUSAL, STATUSES

    per: dict = {}
    false = []
    for r in results:
        for c in r.get("cross_check", ()):
            entry = per.setdefault(c["reason"], {"refusals": 0, **{k: 0 for k in STATUSES},
                                                 "by_method": {}, "examples": {},
                                                 "seconds": []})
            entry["refusals"] += 1
            entry[c["status"]] += 1
            entry["examples"].setdefault(c["status"], {"seed": r["seed"], "target": c["target"],
                                                       "detail": c["detail"]})
            if c["status"] in (CONFIRMED, FALSE_REFUSAL):
                entry["by_method"][c["method"]] = entry["by_method"].get(c["method"], 0) + 1
            entry["seconds"].append(c["seconds"])
            if c["status"] == FALSE_REFUSAL:
                false.append({"seed": r["seed"], "target": c["target"], "reason": c["reason"],
                              "detail": c["detail"]})
    for entry in per.values():
        t = entry.pop("seconds")
        entry["seconds_median"] = round(float(np.median(t)), 3)
        entry["seconds_max"] = round(float(np.max(t)), 3)
    decided = sum(e[CONFIRMED] + e[FALSE_REFUSAL] for e in per.values())
    spent = [r["timings"]["cross_check"] for r in results if "cross_check" in r.get("timings", {})]
    return {"refusals_cross_checked": decided, "false_refusals": len(false),
            "refusals_not_decided": sum(e["refusals"] for e in per.values()) - decided,
            "cross_check_seconds": round(float(np.sum(spent)), 1) if spent else 0.0,
            "cross_check": dict(sorted(per.items(), key=lambda kv: -kv[1]["refusals"])),
            "false_refusal_list": false}


def summarize(results: list, meta: dict) -> dict:
    """The contents of fuzz.json: counts per category (each with an example seed and its
    one-line description), per failure reason, per feature; every non-passing seed."""
    categories = {}
    for name, meaning in CATEGORIES.items():
        hits = [r for r in results if r["category"] == name]
        categories[name] = {"count": len(hits), "meaning": meaning}
        if hits:
            categories[name].update(example_seed=hits[0]["seed"], example=hits[0]["detail"])
    reasons: dict = {}
    for r in results:
        if r["category"] == "failure_with_reason":
            key = _reason_key(r)
            entry = reasons.setdefault(key, {"count": 0, "example_seed": r["seed"],
                                             "example": r["detail"]})
            entry["count"] += 1
    features = {}
    for f in FEATURES:
        hits = [r for r in results if f in r["features"]]
        features[f] = {"scenes": len(hits), **{c: n for c in CATEGORIES
                                               if (n := sum(r["category"] == c for r in hits))}}
    bad = [{"seed": r["seed"], "category": r["category"], "detail": r["detail"]}
           for r in results if r["category"] not in GOOD]
    times = [r["time_s"] for r in results if r.get("time_s") is not None]
    warned: dict = {}
    for r in results:
        for w in r.get("warnings", ()):
            entry = warned.setdefault(w, {"scenes": 0, "example_seed": r["seed"]})
            entry["scenes"] += 1
    slowest = sorted((r for r in results if r.get("time_s") is not None),
                     key=lambda r: -r["time_s"])[:5]
    cross = cross_check_summary(results)
    return {**meta, "scenes": len(results),
            "passed": sum(r["category"] in GOOD for r in results),
            "seconds_per_scene_median": round(float(np.median(times)), 3) if times else None,
            "categories": categories,
            "failure_reasons": dict(sorted(reasons.items(), key=lambda kv: -kv[1]["count"])),
            "features": features, "not_passing": bad, **cross,
            "python_warnings": dict(sorted(warned.items(), key=lambda kv: -kv[1]["scenes"])),
            "slowest": [{"seed": r["seed"], "time_s": r["time_s"], "category": r["category"],
                         "rig": r["rig"], "task": r["task"]} for r in slowest]}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--count", type=int, default=10000, help="scenes (default 10000)")
    parser.add_argument("--seed0", type=int, default=0, help="first seed (default 0)")
    parser.add_argument("--jobs", type=int, default=os.cpu_count() or 1,
                        help="worker processes (default: the number of cores)")
    parser.add_argument("--out", default=str(ROOT / "bench" / "fuzz.json"), help="results file")
    parser.add_argument("--subframes", type=int, default=SUBFRAMES,
                        help=f"instants checked between two frames (default {SUBFRAMES})")
    parser.add_argument("--timeout", type=float, default=600.0, help="seconds per scene at most")
    parser.add_argument("--keep", metavar="DIR",
                        help="run in this process and keep each scene's files in DIR (for one seed)")
    parser.add_argument("--cross-check-budget", type=float, default=CROSS_CHECK_BUDGET_S,
                        metavar="SECONDS",
                        help="OMPL's seconds per refusal in the cross-check where a goal "
                             f"region exists (default {CROSS_CHECK_BUDGET_S:g}; 0: no "
                             "cross-check)")
    parser.add_argument("--standard-rigs", action="store_true",
                        help="synthetic rigs as before their shapes varied (A pose, one hand "
                             "bone): replays a seed of an older campaign")
    parser.add_argument("--quick", action="store_true",
                        help="the cheaper scenes of the tests' subset (smaller search budgets)")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--results", help=argparse.SUPPRESS)
    parser.add_argument("--seeds", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.worker:
        worker([int(s) for s in args.seeds.split(",")], Path(args.results), args.subframes,
               quick=args.quick, cross_check_s=args.cross_check_budget,
               shapes=not args.standard_rigs)
        return 0
    seeds = list(range(args.seed0, args.seed0 + args.count))
    if args.keep:
        keep = Path(args.keep).resolve()
        keep.mkdir(parents=True, exist_ok=True)
        results_path = keep / "results.jsonl"
        results_path.unlink(missing_ok=True)
        worker(seeds, results_path, args.subframes, keep=keep, quick=args.quick,
               cross_check_s=args.cross_check_budget, shapes=not args.standard_rigs)
        for seed in seeds:
            print(json.dumps(generate(seed, args.quick, not args.standard_rigs), indent=1))
        for line in results_path.read_text().splitlines():
            rec = json.loads(line)
            if "category" in rec:
                print(f"seed {rec['seed']}: {rec['category']}: {rec['detail']}")
                if rec.get("traceback"):
                    print(rec["traceback"])
                for c in rec.get("cross_check", ()):
                    print(f"  cross-check '{c['target']}' {c['reason']}: {c['status']} "
                          f"({c['seconds']:.2f} s): {c['detail']}")
        return 0

    def progress(done, total, elapsed, state={"last": 0.0}):   # noqa: B006
        if elapsed - state["last"] >= 30 or done == total:
            state["last"] = elapsed
            print(f"fuzz: {done}/{total} scenes, {elapsed:.0f} s", flush=True)

    from bench.tight import git_commit

    commit = git_commit()       # before the run: what the workers import from disk
    t0 = time.perf_counter()
    results = run_campaign(seeds, args.jobs, args.subframes, args.timeout, progress, args.quick,
                           args.cross_check_budget, not args.standard_rigs)
    import bpy  # noqa: F401  (the versions below)

    from reach_addon import __version__

    meta = {"generated_by": "bench/fuzz.py (make fuzz)", "reach_version": __version__,
            "reach_commit": commit,
            "blender_version": bpy.app.version_string, "seed0": args.seed0, "count": args.count,
            "jobs": args.jobs, "subframes": args.subframes, "quick": args.quick,
            "cross_check_budget_s": args.cross_check_budget, "rig_shapes": not args.standard_rigs,
            "wall_time_s": round(time.perf_counter() - t0, 1)}
    summary = summarize(results, meta)
    from reach_addon import atomic

    atomic.write_text(Path(args.out), json.dumps(summary, indent=1, ensure_ascii=False) + "\n")
    cats = ", ".join(f"{k} {v['count']}" for k, v in summary["categories"].items() if v["count"])
    print(f"fuzz: {summary['passed']}/{len(results)} passed ({cats}); refusals cross-checked "
          f"{summary['refusals_cross_checked']}, false refusals {summary['false_refusals']}, "
          f"undecided {summary['refusals_not_decided']} ({summary['cross_check_seconds']:.0f} s "
          f"of cross-check); wrote {args.out}")
    return 0 if summary["passed"] == len(results) else 1


if __name__ == "__main__":
    sys.exit(main())
