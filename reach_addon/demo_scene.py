"""The demo's scene in Blender (:func:`reach_addon.demo.scene_demo`): the character and
the workplace built round it, the poses it returns to between tasks, the side table and
camera of its step task, and the pictures joined from its stills.

Every function imports ``bpy`` itself: :mod:`reach_addon.demo` (and the core's tests,
which read its workplace) import this module without Blender.
"""

from __future__ import annotations

import numpy as np

from .core import Task
from .samples import HANGING

#: The character: Quaternius' "Female Casual" (CC0, see tests/data/rigs/), with a skinned body.
DEMO_RIG = "Quaternius_Female_Casual.fbx"
COLOURS = {"Table": (0.55, 0.36, 0.2, 1), "Crate": (0.75, 0.6, 0.3, 1),
           "Shelf": (0.45, 0.47, 0.5, 1), "Floor": (0.8, 0.8, 0.78, 1),
           "Side Table": (0.5, 0.33, 0.2, 1)}
#: Frames in which the body stands up again after the whole-body task, before the step.
BODY_GAP = 36
#: The demo's step task, after it: something ``STEP_SIDE`` arm lengths to her right and
#: ``STEP_BELOW`` under her shoulder (the issue's step: 2.3 to the side), on a side table
#: whose top is ``STEP_TABLE_UNDER`` arm lengths under it.
STEP_SIDE, STEP_BELOW, STEP_TABLE_UNDER = 2.3, 0.3, 0.2
#: The camera for the step (where it stands, the point it looks at; metres): behind her,
#: so that she steps to the picture's right, the side table in view.
STEP_CAMERA = ((-1.0, 3.4, 2.4), (-1.0, -0.1, 0.9))


def rig_file():
    from pathlib import Path

    from .core import ReachError

    path = Path(__file__).resolve().parents[1] / "tests" / "data" / "rigs" / DEMO_RIG
    if not path.is_file():
        raise ReachError(f"the demo character '{path}' is missing; run the demo from a "
                         "checkout of Reach (make demo)")
    return path


def _material(name, colour):
    import bpy

    mat = bpy.data.materials.get(name) or bpy.data.materials.new(name)
    mat.diffuse_color = colour
    return mat


def _box_object(name, parts, colour):
    import bpy

    from .samples import triangle_soup

    verts, tris, _owners, _names = triangle_soup({name: parts})
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts.tolist(), [], tris.tolist())
    mesh.update()
    ob = bpy.data.objects.new(name, mesh)
    ob.data.materials.append(_material(name, colour))
    bpy.context.scene.collection.objects.link(ob)
    return ob


def empty(name, location, shape="SPHERE", size=0.025):
    import bpy

    ob = bpy.data.objects.new(name, None)
    ob.empty_display_type, ob.empty_display_size = shape, size
    ob.location = tuple(map(float, location))
    bpy.context.scene.collection.objects.link(ob)
    return ob


def build_scene(workplace: dict):
    """An empty file with the demo character standing where the core's standard figure
    stands (facing −Y, chest at 1.40 m, scaled to the same arm length), the ``workplace``
    furniture ({name: boxes}, :data:`reach_addon.demo.WORKPLACE`), a camera and a light.
    Returns the armature."""
    import bpy
    from mathutils import Matrix, Vector

    from .blender import rig as rig_mod
    from .samples import standard_arm

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.import_scene.fbx(filepath=str(rig_file()))
    armature = next(o for o in scene.objects if o.type == "ARMATURE")
    # The file's own clip (she claps) would move the body under the reach: stand still.
    if armature.animation_data is not None:
        armature.animation_data.action = None
    for pb in armature.pose.bones:
        pb.matrix_basis = Matrix.Identity(4)
    root = armature
    while root.parent is not None:
        root = root.parent
    bpy.context.view_layer.update()
    info = rig_mod.build(armature, "right")
    f = info.frame
    body = np.column_stack([f.right, f.forward, f.up])
    world = np.array([[-1.0, 0, 0], [0, -1.0, 0], [0, 0, 1.0]]).T
    rot = world @ body.T
    k = standard_arm().arm_length / info.arm.arm_length
    m = np.eye(4)
    m[:3, :3] = k * rot
    m[:3, 3] = np.array([0.0, 0.0, 1.40]) - k * rot @ f.origin
    root.matrix_world = Matrix(m.tolist()) @ root.matrix_world
    bpy.context.view_layer.update()
    # then put her right shoulder where the standard figure's is (the targets are its)
    std = standard_arm()
    want = std.to_world_points(std.shoulder)
    have = rig_mod.build(armature, "right").joints_world["shoulder"]
    root.matrix_world = Matrix.Translation((want - have).tolist()) @ root.matrix_world
    bpy.context.view_layer.update()
    arms_down(armature, rig_mod.build(armature, "right"))

    for name, parts in workplace.items():
        _box_object(name, parts, COLOURS[name])
    # the floor's top under her soles (scaled to the standard figure, they stand 5.5 cm
    # lower than its feet)
    top = soles(armature)
    floor = _box_object("Floor", [((-2.0, -2.0, top - 0.02), (2.0, 2.0, top))],
                        COLOURS["Floor"])
    floor.hide_select = True
    cam_data = bpy.data.cameras.new("Camera")
    cam_data.lens = 30
    cam = bpy.data.objects.new("Camera", cam_data)
    scene.collection.objects.link(cam)
    cam.location = (-2.2, 1.1, 2.5)
    look = Vector((-0.25, -0.3, 1.1)) - cam.location
    cam.rotation_euler = look.to_track_quat("-Z", "Y").to_euler()
    scene.camera = cam
    sun = bpy.data.objects.new("Sun", bpy.data.lights.new("Sun", "SUN"))
    scene.collection.objects.link(sun)
    sun.rotation_euler = (0.6, 0.2, -0.5)
    scene.render.fps = 24
    return armature


def soles(armature) -> float:
    """The height of the lowest vertex of the meshes ``armature`` deforms, as Blender
    evaluates them now: where the floor's top goes."""
    import bpy

    depsgraph = bpy.context.evaluated_depsgraph_get()
    low = np.inf
    for ob in bpy.context.scene.objects:
        if ob.type == "MESH" and any(m.type == "ARMATURE" and m.object == armature
                                     for m in ob.modifiers):
            ev = ob.evaluated_get(depsgraph)
            co = np.empty(len(ev.data.vertices) * 3)
            ev.data.vertices.foreach_get("co", co)
            m = np.array(ev.matrix_world)
            low = min(low, float((co.reshape(-1, 3) @ m[:3, :3].T + m[:3, 3])[:, 2].min()))
    return low if np.isfinite(low) else 0.0


def arms_down(armature, info):
    """Lower both arms from the file's T-pose to hanging, a little out and forward, as the
    paper's subject starts (the start pose is the pose, not a key)."""
    from mathutils import Matrix, Vector

    inv = armature.matrix_world.inverted().to_3x3()
    f = info.frame
    for side, arm in info.bones.arms.items():
        out = f.right if side == "right" else -f.right
        want = (inv @ Vector((-0.94 * f.up + 0.28 * out + 0.12 * f.forward).tolist())).normalized()
        pb = armature.pose.bones[arm.upper_arm]
        head = pb.head.copy()
        turn = (pb.tail - pb.head).normalized().rotation_difference(want).to_matrix().to_4x4()
        pb.matrix = Matrix.Translation(head) @ turn @ Matrix.Translation(-head) @ pb.matrix
        bpy_update()


def bpy_update():
    import bpy

    bpy.context.view_layer.update()


def keep_display(scene, task_name):
    """Keep this task's trajectory and markers in the file, in a collection of its own that
    the next plan does not clear and the next renders do not show."""
    from .blender import viz
    from .blender.scene import VIZ_TAG

    coll = viz.collection(scene, create=False)
    if coll is not None:
        coll.name = f"Reach {task_name}"
        for ob in coll.objects:          # the next plan makes its own, not reuses these
            ob.name = f"{ob.name} ({task_name})"
        del coll[VIZ_TAG]
        coll.hide_render = True


def pose_of(armature, bones):
    """The start pose of the bones a bake keys (chest and arm), to return to between
    tasks: each of the paper's tasks starts from the same standing pose."""
    return {b: armature.pose.bones[b].matrix_basis.copy() for b in bones}


def key_pose(armature, rest, frame):
    for name, basis in rest.items():
        pb = armature.pose.bones[name]
        pb.matrix_basis = basis
        mode = pb.rotation_mode
        path = ("rotation_quaternion" if mode == "QUATERNION" else
                "rotation_axis_angle" if mode == "AXIS_ANGLE" else "rotation_euler")
        pb.keyframe_insert(path, frame=frame)
        pb.keyframe_insert("location", frame=frame)


def rest_body(armature, standing, first: int, last: int, at: int) -> None:
    """Key the bones Reach keyed as the body's on frames ``first``..``last`` (the spine's
    and the pelvis's share of the chest's turn, the legs under a turned pelvis) back to
    ``standing`` on frame ``at``, recorded as Reach's own keys there (the demo's, not a
    user's: the next task may move them again)."""
    from .blender import own_keys

    body = _keyed_bones(armature, first, last)
    if body:
        key_pose(armature, {n: standing[n] for n in body}, at)
        own_keys.record(armature.animation_data.action, body, last + 1, at)


def _keyed_bones(armature, first: int, last: int) -> list:
    """The bones Reach keyed on frames ``first``..``last`` (:mod:`.blender.own_keys`)."""
    from .blender import own_keys

    return sorted(own_keys.overlapping(armature, first, last))


def cut_to(camera, view, frame: int) -> None:
    """Key ``camera`` where it is on the frame before ``frame`` and at ``view`` (its
    location, the point it looks at) on ``frame``: a cut, at whole frames."""
    from mathutils import Vector

    for f, at in ((frame - 1, None), (frame, view)):
        if at is not None:
            location, look = at
            camera.location = location
            camera.rotation_euler = (Vector(look) - camera.location).to_track_quat(
                "-Z", "Y").to_euler()
        camera.keyframe_insert("location", frame=f)
        camera.keyframe_insert("rotation_euler", frame=f)


def stand_up(armature, standing, first: int, last: int) -> None:
    """Key every bone that stands otherwise on frame ``last`` than in ``standing`` (its pose
    before the demo) back to it :data:`BODY_GAP` frames later; those Reach keyed as the
    body's on frames ``first``..``last`` recorded as Reach's own keys there
    (:mod:`.blender.own_keys`: the demo's, not a user's, so the next task may move the
    hips and legs again)."""
    import bpy

    from .blender import own_keys

    bpy.context.scene.frame_set(last)
    moved = {n: basis for n, basis in standing.items()
             if not _same(armature.pose.bones[n].matrix_basis, basis)}
    key_pose(armature, moved, last + BODY_GAP)
    own_keys.record(armature.animation_data.action, _keyed_bones(armature, first, last),
                    last + 1, last + BODY_GAP)


def _same(a, b, tolerance: float = 1e-6) -> bool:
    return float(np.abs(np.array(a) - np.array(b)).max()) <= tolerance


def step_target(armature):
    """The step task: something on a side table :data:`STEP_SIDE` arm lengths to her right
    and :data:`STEP_BELOW` under her shoulder (the issue's step), the table's top
    :data:`STEP_TABLE_UNDER` under it (built here), as a reach Task."""
    from .blender import rig as rig_mod

    info = rig_mod.build(armature, "right")
    f, length = info.frame, info.arm.arm_length
    shoulder = np.asarray(info.joints_world["shoulder"], dtype=float)
    right, up = np.asarray(f.right, dtype=float), np.asarray(f.up, dtype=float)
    thing = shoulder + length * (STEP_SIDE * right - STEP_BELOW * up)
    near, far = (float((thing + k * length * right)[0]) for k in (-0.15, 0.35))  # right: −X
    top = float(thing[2]) - STEP_TABLE_UNDER * length
    _box_object("Side Table", [((far, thing[1] - 0.25, soles(armature)), (near, thing[1] + 0.25,
                                                                           top))],
                COLOURS["Side Table"])
    return Task("reach", thing[None], HANGING, 24.0, names=("on the side table",))


def envelope_still(armature, out_dir, out) -> str:
    """The character's right-arm reach envelope among the workplace, at frame 1 (the rest
    pose), rendered to ``envelope.png``; its mesh is removed again (demo.blend is saved
    without it)."""
    import bpy

    from .blender import envelope as envelope_mod
    from .blender import pipeline, viz
    from .blender.render import render_still

    scene = bpy.context.scene
    scene.frame_set(1)
    hidden = [c for c in scene.collection.children if c.name.startswith(viz.COLLECTION)
              and not c.hide_render]
    for coll in hidden:                         # the tasks' trajectories and markers
        coll.hide_render = True
    try:
        outcome = pipeline.envelope(bpy.context, pipeline.Request(
            armature=armature.name, targets=[], side="right"))
        mesh = envelope_mod.write_mesh(bpy.context, outcome)
        points, _classes = envelope_mod.drawn(outcome)
        path = render_still(bpy.context, outcome.rig, points, out_dir / "envelope.png")
        viz.remove(mesh.name)
    finally:
        for coll in hidden:
            coll.hide_render = False
    counts = outcome.envelope.counts()
    print(f"{'envelope':15s} {len(outcome.envelope.classes)} points in "
          f"{outcome.envelope.time_s:.2f} s: " + ", ".join(f"{n} {c}" for c, n in counts.items())
          + "; rendered envelope.png", file=out, flush=True)
    return path


def strip(out_dir, names, filename, width=480, gap=6) -> str:
    """The tasks' stills (``<name>.png``) side by side, each scaled to ``width`` pixels,
    as one PNG (``filename``, for the README)."""
    import bpy

    from . import atomic

    tiles = []
    for name in names:
        img = bpy.data.images.load(str(out_dir / f"{name}.png"))
        img.scale(width, round(img.size[1] * width / img.size[0]))
        px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
        img.pixels.foreach_get(px)
        tiles.append(px.reshape(img.size[1], img.size[0], 4))
        bpy.data.images.remove(img)
    height = max(t.shape[0] for t in tiles)
    strip = np.ones((height, len(tiles) * (width + gap) - gap, 4), np.float32)
    for k, tile in enumerate(tiles):
        strip[height - tile.shape[0]:, k * (width + gap):k * (width + gap) + width] = tile
    img = bpy.data.images.new("Reach demo strip", strip.shape[1], height, alpha=False)
    img.pixels.foreach_set(strip.ravel())
    path = out_dir / filename
    with atomic.replacing(path) as tmp:
        img.filepath_raw = str(tmp)
        img.file_format = "PNG"
        img.save()
    bpy.data.images.remove(img)
    return str(path)
