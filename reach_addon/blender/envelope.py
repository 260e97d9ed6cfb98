"""The reach envelope in Blender: its cache, a mesh of it (so it renders and exports) and a
CSV of it. Computing it is the pipeline's (:func:`~.pipeline.envelope_steps`); the classes
are the core's (:mod:`reach_addon.core.envelope`); the viewport overlay is the UI's
(:mod:`reach_addon.ui.envelope`).

**Cache.** An envelope is kept per scene with a key of everything it depends on: the
armature's world matrix and every pose bone's matrix, the frames its action keys (a key
on the lean bone takes the lean and squat classes away), the obstacles' signature
(:class:`~.scene.ObstacleCache`: each obstacle's matrix, data and geometry edits), the
settings, the arm, the bone map and the obstacle collection. :func:`cached` returns it only
while that key is unchanged: once the rig's pose, the scene or the settings change, the
envelope is computed again.
"""

from __future__ import annotations

import csv
import hashlib
import io
import json
from pathlib import Path

import bmesh
import bpy
import numpy as np
from mathutils import Matrix

from .. import atomic
from ..core.envelope import CLASSES, COLOURS, OUT
from ..core.stance import Stance
from . import balance, viz
from . import hips as hips_mod
from .lean import lean_bone
from . import own_keys
from .fcurves import Channels
from .lean_pose import pivot_world
from .scene import VIZ_TAG, ObstacleCache, character_objects, rounded_bytes

MESH_NAME = "Reach Envelope"
#: Each point's octahedron reaches this share of the grid's spacing from its centre.
MARKER_SHARE = 0.22

_cache: dict = {}          # scene name -> (key, EnvelopeOutcome)


def read_stance(armature, info, settings) -> Stance | None:
    """The body as it stands now (:class:`~reach_addon.core.stance.Stance`, world), for the
    envelope's squat and step classes; None without Lean, where Reach finds no legs or
    no bone to lean the trunk (:func:`.lean.lean_bone`), or where the legs lean past
    :data:`.balance.STANDING_TILT` off the scene's gravity
    (:func:`.balance.standing_why_not`), as a reach would not lean, squat or step there;
    with the lean bone keyed by the user, a stance that steps only (``trunk_free``), as a
    reach then refuses to lean.
    Its margin is a reach's: ``Settings.balance_margin`` arm lengths inside the feet, over
    the rig's own where it stands past them."""
    if not settings.lean:
        return None
    legs = balance.find_legs(armature, info.bones, info.frame)
    bone = lean_bone(armature, info.bones, legs)
    if bone is None or balance.standing_why_not(armature, legs, info.frame.ground,
                                                "lean") is not None:
        return None
    up = np.asarray(info.frame.ground, dtype=float)
    ankles, leg_length = balance.ankles_now(armature, legs)
    floor = min(0.0, balance.margin_now(armature, info.bones, legs, up))
    return Stance(
        segments=tuple(balance.body_segments(armature, info.bones, legs)),
        arm=3 * list(info.bones.arms).index(info.side),
        pivot=pivot_world(armature, bone), to_world=np.asarray(info.arm.to_world, float),
        polygon=balance.support_now(armature, legs, up)[0], up=up,
        planted_share=hips_mod.PLANTED_SHARE, floor=floor,
        margin=floor + settings.balance_margin * info.arm.arm_length,
        leg_joints=tuple(hips_mod.leg_joints(armature, legs,
                                             np.asarray(info.frame.forward, float))),
        ankles=ankles, leg_length=leg_length,
        shoulder=np.asarray(info.joints_world["shoulder"], dtype=float),
        ground=balance.ground_now(armature, legs, up),
        trunk_free=not own_keys.users_keys(armature, bone))


def state_key(context, request) -> str:
    """A digest of everything the envelope of ``request`` depends on (module docstring)."""
    armature = bpy.data.objects.get(request.armature)
    if armature is None or armature.type != "ARMATURE":
        return ""
    pose = np.array([np.array(pb.matrix) for pb in armature.pose.bones], float)
    targets = [n for n in request.targets if n in bpy.data.objects]
    exclude = character_objects(armature, context.scene) | set(targets)
    signature = ObstacleCache(exclude, request.obstacles).compute_signature(context)
    h = hashlib.sha1()
    # (to 1e-6: a bone turned and turned back by hand comes back within float32 rounding)
    h.update(rounded_bytes(np.array(armature.matrix_world), 6))
    h.update(rounded_bytes(pose, 6))
    h.update(repr(signature).encode())
    _keys_digest(h, armature)
    h.update(json.dumps([request.settings.to_dict(), request.side, request.overrides,
                         request.obstacles, targets], sort_keys=True, default=str).encode())
    return h.hexdigest()


def _keys_digest(h, armature) -> None:
    """Feed ``h`` the frames the armature's action keys on each channel and Reach's record
    of its own (:mod:`.own_keys`): a key a user sets on the bone that leans the trunk, the
    pose unchanged, takes the lean and squat classes away (:func:`read_stance`)."""
    ad = armature.animation_data
    action = ad.action if ad else None
    if action is None:
        return
    h.update(action.name_full.encode())
    h.update(str(action.get(own_keys.PROPERTY, "")).encode())
    for fc in Channels(armature, action).bag.fcurves:
        pts = fc.keyframe_points
        co = np.empty(2 * len(pts), np.float32)
        pts.foreach_get("co", co)
        h.update(f"{fc.data_path}[{fc.array_index}]".encode())
        h.update(co[0::2].tobytes())


def store(context, outcome, key: str) -> None:
    _cache[context.scene.name] = (key, outcome)


def cached(context, request):
    """The scene's envelope if it is still the envelope of ``request`` as the scene is now,
    else None."""
    entry = _cache.get(context.scene.name)
    if entry is None:
        return None
    key, outcome = entry
    return outcome if key and key == state_key(context, request) else None


def last(scene):
    """The scene's last envelope, whether or not it is still current (for drawing)."""
    entry = _cache.get(scene.name)
    return entry[1] if entry else None


def forget(scene) -> None:
    _cache.pop(scene.name, None)


def drawn(outcome):
    """(world points (k, 3), class codes (k,)) of the points that are drawn: all but
    ``out``."""
    classes = outcome.envelope.classes
    keep = classes != OUT
    return outcome.world[keep], classes[keep]


def spacing(outcome) -> float:
    """The grid's spacing in world units (the arm's frame is a rigid turn of the world's)."""
    s = outcome.request.settings
    return 2.0 * s.envelope_extent * outcome.rig.arm.arm_length / (max(2, s.envelope_resolution) - 1)


def write_mesh(context, outcome, colours=COLOURS, name: str = MESH_NAME):
    """The envelope as a mesh in the "Reach" collection: a small octahedron per drawn point,
    one material per class (Workbench, EEVEE, Cycles and exporters show the class colours)
    and a point colour attribute ``reach_class_colour`` with the same colours (``colours``:
    RGBA per class code, default :data:`~reach_addon.core.envelope.COLOURS`). Replaces the
    previous one."""
    viz.remove(name)
    points, classes = drawn(outcome)
    r = MARKER_SHARE * spacing(outcome)
    bm = bmesh.new()
    try:
        for p in points:
            bmesh.ops.create_icosphere(bm, subdivisions=0, radius=r,
                                       matrix=Matrix.Translation(p.tolist()))
        per_point = len(bm.verts) // max(1, len(points))
        per_face = len(bm.faces) // max(1, len(points))
        for k, face in enumerate(bm.faces):
            face.material_index = int(classes[k // per_face])
        mesh = bpy.data.meshes.new(name)
        bm.to_mesh(mesh)
    finally:
        bm.free()
    mesh[VIZ_TAG] = True
    for k, label in enumerate(CLASSES):
        mesh.materials.append(viz.material(f"Reach Envelope {label}", tuple(colours[k])))
    rgba = np.repeat(np.array([colours[c] for c in classes], np.float32), per_point, axis=0)
    attr = mesh.color_attributes.new("reach_class_colour", "FLOAT_COLOR", "POINT")
    attr.data.foreach_set("color", rgba.ravel())
    return viz.link(context.scene, bpy.data.objects.new(name, mesh), tuple(colours[0]))


def csv_text(outcome) -> str:
    """One row per grid point: its index, world position, shoulder-frame coordinates
    (forward, outward, up; arm lengths, as a batch study's shoulder grid), class and f_R
    (-1 where no pose is chosen)."""
    out = io.StringIO()
    w = csv.writer(out, lineterminator="\n")
    w.writerow(["index", "x", "y", "z", "forward", "outward", "up", "class", "f_r"])
    env = outcome.envelope
    for i, (p, c) in enumerate(zip(outcome.world, outcome.shoulder)):
        w.writerow([i, *(f"{v:.6f}" for v in p), *(f"{v:.6f}" for v in c),
                    CLASSES[int(env.classes[i])], int(env.f_r[i])])
    return out.getvalue()


def write_csv(outcome, path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    atomic.write_text(path, csv_text(outcome))
    return path
