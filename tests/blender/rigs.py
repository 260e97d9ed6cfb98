"""Real rigs for the Blender tests, and scenes built around them.

The seven files in ``tests/data/rigs`` (see their licences and ``README.md`` there) plus
Rigify's human metarig and the rig Rigify generates from it. Every loader starts from an
empty file and returns the character's body armature.

:data:`RIGS` are the five kinds most tests run on (their bones and joints are pinned in
``test_rig_detection``); :data:`SHARED_RIGS` the four files added later, kept apart so that
the tests parametrised by :data:`RIGS` keep their size; :data:`FILE_RIGS` every rig read
from a file.
"""

from __future__ import annotations

import functools
import tempfile
from pathlib import Path

import addon_utils
import bpy
import numpy as np

DATA = Path(__file__).resolve().parents[1] / "data" / "rigs"
RIGS = ("cesium", "quaternius", "gomakehuman", "metarig", "rigify")
#: Quaternius' Goblin, Alien and Knight (FBX) and orange-juice-games' Male Base Mesh (glTF).
SHARED_RIGS = ("goblin", "alien", "knight", "malebase")
#: Every rig read from a file in ``tests/data/rigs``.
FILE_RIGS = ("cesium", "quaternius", "gomakehuman") + SHARED_RIGS
#: The file of each kind read by an importer.
FILES = {"cesium": "CesiumMan.glb", "quaternius": "Quaternius_Female_Casual.fbx",
         "goblin": "Quaternius_Goblin.fbx", "alien": "Quaternius_Alien.fbx",
         "knight": "Quaternius_Knight.fbx", "malebase": "MaleBaseMesh_metarig.glb"}


def fcurves(action) -> list:
    """Every F-curve of an action, whatever the action API: ``Action.fcurves`` (before 4.4)
    or layers → strips → channelbags (slotted actions)."""
    if hasattr(action, "layers"):
        return [fc for layer in action.layers for strip in layer.strips
                for bag in strip.channelbags for fc in bag.fcurves]
    return list(action.fcurves)


def empty_file():
    bpy.ops.wm.read_homefile(use_empty=True)
    return bpy.context.scene


def _only_armature():
    arms = [o for o in bpy.context.scene.objects if o.type == "ARMATURE"]
    assert len(arms) == 1, [o.name for o in arms]
    return arms[0]


def body_armature():
    """The character's body armature among the scene's armatures: the one with the most
    bones (a file may hold small armatures of its own beside it, such as the Goblin's
    2-bone ``FaceArmature`` that moves its face mesh). Asserts there is one, and that no
    other comes near it (half its bones), so the rule never picks by a hair."""
    arms = sorted((o for o in bpy.context.scene.objects if o.type == "ARMATURE"),
                  key=lambda o: len(o.data.bones), reverse=True)
    assert arms, "no armature in the file"
    assert len(arms) == 1 or len(arms[1].data.bones) < 0.5 * len(arms[0].data.bones), \
        [(o.name, len(o.data.bones)) for o in arms]
    return arms[0]


def load(kind: str):
    """Load one test rig into an empty file; returns its body armature. Importers leave
    the file's first clip playing: :func:`rest_still` stops it."""
    empty_file()
    path = DATA / FILES.get(kind, "")
    if kind in ("cesium", "malebase"):
        # without the icosphere the glTF importer adds as the bones' custom shape: it is
        # a mesh of faces, which Reach would take for an obstacle
        bpy.ops.import_scene.gltf(filepath=str(path), disable_bone_shape=True)
        return body_armature()
    if kind in ("quaternius", "goblin", "alien", "knight"):
        bpy.ops.import_scene.fbx(filepath=str(path))
        return body_armature()
    if kind == "gomakehuman":
        _append(DATA / "GoMakeHuman_simple_IK_rig.blend")
        return _only_armature()
    if kind == "metarig":
        addon_utils.enable("rigify", default_set=True)
        bpy.ops.object.armature_human_metarig_add()
        bpy.ops.object.mode_set(mode="OBJECT")
        return bpy.context.object
    if kind == "rigify":
        _append(_generated_rig_file())
        return bpy.data.objects["rig"]
    raise ValueError(kind)


def _append(path):
    with bpy.data.libraries.load(str(path), link=False) as (src, dst):
        dst.objects = list(src.objects)
    for ob in dst.objects:
        if ob is not None:
            bpy.context.scene.collection.objects.link(ob)


@functools.lru_cache(maxsize=1)
def _generated_rig_file() -> Path:
    """Generate Rigify's rig from the human metarig once per session; saved to a .blend
    that each test appends (generation takes about 10 s)."""
    empty_file()
    addon_utils.enable("rigify", default_set=True)
    bpy.ops.object.armature_human_metarig_add()
    metarig = bpy.context.object
    bpy.context.view_layer.objects.active = metarig
    bpy.ops.pose.rigify_generate()
    path = Path(tempfile.mkdtemp(prefix="reach-rigify-")) / "rigify.blend"
    for ob in list(bpy.context.scene.objects):
        if ob.name != "rig":
            bpy.data.objects.remove(ob, do_unlink=True)
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    return path


def rest_still(armature):
    """Stop the clip an importer left playing (CesiumMan walks, the Quaternius figures clap,
    attack or die) so the body holds still while the arm is baked: unassign the action and return every pose
    bone to rest."""
    from mathutils import Matrix

    ad = armature.animation_data
    if ad is not None and ad.action is not None:
        ad.action = None
    for pb in armature.pose.bones:
        pb.matrix_basis = Matrix.Identity(4)
    bpy.context.scene.frame_set(1)
    bpy.context.view_layer.update()


def height(armature) -> float:
    """How tall the character is (world units): the vertical extent of the meshes it
    deforms or carries, as Blender evaluates them."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    zs = []
    for ob in armature.children_recursive if hasattr(armature, "children_recursive") \
            else armature.children:
        if ob.type != "MESH":
            continue
        ev = ob.evaluated_get(depsgraph)
        mesh = ev.to_mesh()
        co = np.array([v.co[:] for v in mesh.vertices]) @ np.array(ob.matrix_world)[:3, :3].T
        zs += [co[:, 2].min() + ob.matrix_world.translation.z,
               co[:, 2].max() + ob.matrix_world.translation.z]
        ev.to_mesh_clear()
    return float(max(zs) - min(zs))


def small_scale(armature, tall=0.2, object_scale=0.0012):
    """Make the character ``tall`` metres high the way a Mixamo import is small: its bones
    and meshes in large units under an armature object scaled by ``object_scale`` (the
    data scaled up and applied, then the object scaled down). Returns the armature."""
    k = tall / (object_scale * height(armature))
    bpy.ops.object.select_all(action="DESELECT")
    for ob in [armature] + list(armature.children):
        ob.select_set(True)
    bpy.context.view_layer.objects.active = armature
    armature.scale = (k, k, k)
    bpy.context.view_layer.update()
    bpy.ops.object.transform_apply(location=False, rotation=False, scale=True)
    armature.scale = (object_scale,) * 3
    bpy.ops.object.select_all(action="DESELECT")
    bpy.context.view_layer.update()
    return armature


# --- scenes ---------------------------------------------------------------------------------

def add_box(name, center, size, rotation=None):
    """A closed box mesh object (world space): edge lengths ``size`` along the columns of
    ``rotation`` (identity if None), centred at ``center``."""
    from mathutils import Matrix

    bpy.ops.mesh.primitive_cube_add(size=1.0)
    ob = bpy.context.object
    ob.name = name
    m = np.eye(4)
    m[:3, :3] = (np.eye(3) if rotation is None else np.asarray(rotation)) * np.asarray(size)[None, :]
    m[:3, 3] = center
    ob.matrix_world = Matrix(m.tolist())
    bpy.context.view_layer.update()
    return ob


def add_target(name, location):
    ob = bpy.data.objects.new(name, None)
    ob.empty_display_type = "SPHERE"
    ob.empty_display_size = 0.02
    ob.location = tuple(location)
    bpy.context.scene.collection.objects.link(ob)
    return ob


def plate_scene(info, armature):
    """A target in front of the reaching shoulder and a plate square across the straight
    line from the start wrist to it, half way: the straight path is blocked whatever the
    rig's rest pose, and the hand can go round the plate on any side. Sized in the rig's own
    arm lengths and body axes."""
    f = info.frame
    length = info.arm.arm_length
    side = f.right if info.side == "right" else -f.right
    shoulder = info.joints_world["shoulder"]
    wrist = info.joints_world["wrist"]
    target = shoulder + f.forward * 0.7 * length + side * 0.15 * length + f.up * 0.05 * length
    path = target - wrist
    span = float(np.linalg.norm(path))
    normal = path / span
    across = np.cross(normal, f.up)
    if np.linalg.norm(across) < 1e-6:
        across = np.cross(normal, f.forward)
    across /= np.linalg.norm(across)
    third = np.cross(normal, across)
    rot = np.column_stack([across, third, normal])
    size = (0.36 * span, 0.36 * span, 0.05 * length)
    plate = add_box("Plate", wrist + 0.5 * path, size, rot)
    return add_target("Cup", target), plate


def table_at_the_hand(info):
    """A box "Table" round the end of the hand of ``info``'s arm as the rig rests (the hand
    in it by a fifth of an arm length, the wrist out) and a target "Inside" in the box:
    the shoulder of that arm is the nearer to it, so Arm: Auto takes that arm, whose
    start pose is inside the box. Returns (table, target)."""
    f, length = info.frame, info.arm.arm_length
    wrist, elbow = info.joints_world["wrist"], info.joints_world["elbow"]
    out = (wrist - elbow) / np.linalg.norm(wrist - elbow)
    hand_end = wrist + out * info.arm.hand_length
    centre = hand_end + out * 0.2 * length
    rotation = np.column_stack([out, f.forward, np.cross(out, f.forward)])
    table = add_box("Table", centre, (0.8 * length, 1.0 * length, 0.6 * length), rotation)
    return table, add_target("Inside", centre + f.forward * 0.3 * length)


def save_cli_scene(kind: str, rig_module, path: Path) -> dict:
    """A file for the command line: rig ``kind`` at rest, the plate scene's target "Cup"
    behind a plate, a free target "Jar" high in front of the chest
    and one, "Inside", in the middle of the plate, saved at ``path``. Returns
    the names and the arm length."""
    arm = load(kind)
    rest_still(arm)
    info = rig_module.build(arm, "right")
    cup, plate = plate_scene(info, arm)
    f, length = info.frame, info.arm.arm_length
    jar = add_target("Jar", info.joints_world["shoulder"] + length * (
        0.5 * f.forward - 0.15 * f.right + 0.35 * f.up))
    inside = add_target("Inside", np.array(plate.matrix_world.translation))
    bpy.ops.wm.save_as_mainfile(filepath=str(path), copy=True)
    return {"armature": arm.name, "targets": [cup.name, jar.name], "inside": inside.name,
            "arm_length": info.arm.arm_length}


def bake_reach(addon, armature, target):
    """Plan and bake a reach of ``armature``'s right arm for ``target`` at frame 1 through
    the pipeline; asserts it succeeded. Returns (outcome, task result, plan, first frame)."""
    request = addon.blender.pipeline.Request(armature=armature.name, targets=[target.name],
                                             side="right", frame_start=1)
    outcome = addon.blender.pipeline.run(bpy.context, request, bake=True)
    res = outcome.results[0]
    assert res.success, res.message
    plan, first = outcome.plans[0]
    return outcome, res, plan, first
