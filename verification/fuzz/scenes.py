"""The fuzz campaign's scenes as plain data: a seed in, a JSON description out.

:func:`generate` turns a seed into a scene description (a dict of JSON values) with numpy's
``default_rng(seed)`` and nothing else, so a seed gives the same bytes on every machine.
Positions are in the reaching shoulder's body frame (side, forward, up) and in the rig's arm
lengths; :func:`verification.fuzz.building.build` turns them into a Blender scene. The
description's ``features`` are the scene features of :data:`FEATURES` it has. What the
scenes hold and why: ``docs/design.md``, *The fuzz campaign*.
"""

from __future__ import annotations

import math

import numpy as np

from ..geometry import unit

SYNTH_MAPS = ("mixamo", "vrm", "unity", "spaced", "makehuman", "unreal", "plain", "numbered")
REAL_RIGS = ("quaternius", "gomakehuman", "metarig", "cesium", "rigify")

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
    "target_past_arm", "target_low", "target_step",
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
#: Planner settings of the quick scenes (the tests' subset): smaller search budgets.
QUICK_SETTINGS = {"node_budget": 1500, "stall_budget": 400, "sampling_budget": 3000,
                  "hand_grid_step": 10.0}


def _pick(rng, items, weights=None):
    if weights is None:
        return items[int(rng.integers(len(items)))]
    p = np.asarray(weights, dtype=float)
    return items[int(rng.choice(len(items), p=p / p.sum()))]


def _random_rotation(rng) -> list:
    """A uniformly random rotation as a quaternion (w, x, y, z)."""
    q = rng.normal(size=4)
    return (q / np.linalg.norm(q)).tolist()


def quat_matrix(q) -> np.ndarray:
    """The rotation matrix (3, 3) of a unit quaternion (w, x, y, z)."""
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


#: The features only a Lean campaign's scenes have (:func:`_whole_body_target`).
LEAN_FEATURES = ("target_past_arm", "target_low", "target_step")
#: With the whole body on, the share of single reaches (and of sequences' and guided
#: reaches' last targets) drawn again past the arm (:func:`_whole_body_target`).
PAST_ARM_SHARE = 0.6


#: The shared rigs with legs a Lean campaign's whole-body scene takes instead of a
#: synthetic rig (the synthetic rigs are arms on a trunk: no legs to lean on).
LEGGED_RIGS = ("quaternius", "gomakehuman", "metarig", "cesium")


def _whole_body_target(rng, spec: dict, t: dict, features: set) -> None:
    """A Lean campaign's single reach, or a sequence's or guided reach's last target (its
    own random stream, so every other draw stays):
    with :data:`PAST_ARM_SHARE`, its target drawn again where the body must help, just past
    the arm (1.0-1.45 arm lengths, ahead or to the side, level or below: a lean), low in
    front (1.5-2.4 arm lengths, 55-85° down: a squat or bend, or the floor's refusal) or
    far, to the side or ahead (1.9-2.6 arm lengths, 0-30° down: a step, or a refusal
    where the room or the steps limit stops it), on a rig with legs
    (:data:`LEGGED_RIGS`, in place of a synthetic one)."""
    if rng.random() >= PAST_ARM_SHARE:
        return
    legged = _pick(rng, LEGGED_RIGS)
    if spec["rig"]["kind"] == "synthetic":
        features.difference_update({f for f in features if f.startswith("rig_")})
        spec["rig"] = {"kind": legged}
        features.add("rig_real")
    features.discard(f"target_{t['kind']}")
    draw = rng.random()
    if draw < 0.45:
        t.update(kind="past_arm", at="shoulder", dist=float(rng.uniform(1.0, 1.45)),
                 dir=_direction(rng, rng.uniform(-20, 100), rng.uniform(-45, 10)))
    elif draw < 0.75:
        t.update(kind="low", at="shoulder", dist=float(rng.uniform(1.5, 2.4)),
                 dir=_direction(rng, rng.uniform(-15, 60), rng.uniform(-85, -55)))
    else:
        t.update(kind="step", at="shoulder", dist=float(rng.uniform(1.9, 2.6)),
                 dir=_direction(rng, rng.uniform(0, 100), rng.uniform(-30, 0)))
    features.add(f"target_{t['kind']}")


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


def generate(seed: int, quick: bool = False, shapes: bool = True, lean: bool = False) -> dict:
    """The scene of ``seed``: plain data (JSON), the same for the same seed on every
    machine. Positions are in the reaching shoulder's body frame (side, forward, up), in
    the rig's arm lengths; :func:`build` makes them world positions.

    ``quick``: the same scene made cheaper to run (the fixed-seed subset of the tests):
    smaller search budgets, Rigify's metarig instead of the generated rig (which takes
    seconds to generate and to evaluate); every feature stays.

    ``shapes`` False: the synthetic rigs of the campaigns before their shapes varied (A
    pose, the elbow bent 30° forward, one hand bone, the standard proportions), so that a
    seed those campaigns found replays its own scene; every other draw is the same.

    ``lean``: the whole body on, *Lean* (and with it *Squat*) and *Look at target*: a
    target beyond the arm is reached by the body where it can be, the head looks at each
    target; every other draw is the same."""
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
    if lean and (task == "reach" and len(targets) == 1 or task in ("sequence", "guided")):
        # a sequence's or guided reach's last target (it leans once, for the farthest)
        _whole_body_target(np.random.default_rng([seed, 4]), spec, targets[-1], features)
        rig = spec["rig"]
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
        spec["body_moves"] = {"delta": unit(body.normal(size=3)).tolist(),
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
    if lean:            # a campaign's setting, not a scene feature (every scene has it)
        spec["settings"]["lean"] = True
        spec["settings"]["gaze"] = True
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
    way = unit(rng.normal(size=3)).tolist()
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
