"""The paper's four tasks on a sample workplace, with the statistics of Table 2 (and, in
Blender, a whole-body fifth: a cup on the floor, Lean and Look at target on).

:func:`core_demo` uses the core alone (the standard figure, furniture as triangle meshes)
and prints our Table 2 beside the paper's.
"""

from __future__ import annotations

import numpy as np

from .core import Planner, Settings, Task
from .samples import HANGING, obstacles, shelf, standard_arm, table

#: Table 2 of the paper: search time (s), nodes searched, nodes in solution, path length
#: (arm lengths).
PAPER_TABLE2 = {
    "collision_free": (2.906, 83, 54, 1.07),
    "rotation": (3.172, 157, 149, 2.99),
    "guided": (3.610, 170, 135, 2.69),
    "chase": (10.156, 426, 282, 5.68),
}

#: The workplace in front of the standard figure (world space, metres).
WORKPLACE = {
    "Table": table((-0.25, -0.62), (1.2, 0.5), 0.92),
    "Crate": [((-0.62, -0.37, 0.93), (0.02, -0.31, 1.10))],
    "Shelf": shelf((-0.62, -0.55), 0.5, 0.3, (1.05, 1.38), back_y_sign=-1),
}


#: The demo's whole-body task, after the paper's four: a cup on the floor beside her,
#: (x, y) in the workplace (metres: 0.36 outward of the right shoulder, 0.05 ahead), the
#: wrist ``WHOLE_BODY_ABOVE`` arm lengths over the floor (the issue's squat-or-bend height;
#: more where the hand's capsule needs it), reached with Lean on, the head looking at it.
WHOLE_BODY_AT = (-0.55, -0.05)
WHOLE_BODY_ABOVE = 0.12
#: The demo's step task, after it: something ``STEP_SIDE`` arm lengths to her right and
#: ``STEP_BELOW`` under her shoulder (the issue's step: 2.3 to the side), on a side table
#: whose top is ``STEP_TABLE_UNDER`` arm lengths under it.
STEP_SIDE, STEP_BELOW, STEP_TABLE_UNDER = 2.3, 0.3, 0.2
#: The camera for the step (where it stands, the point it looks at; metres): behind her,
#: so that she steps to the picture's right, the side table in view.
STEP_CAMERA = ((-1.0, 3.4, 2.4), (-1.0, -0.1, 0.9))


def demo_tasks(fps: float = 24.0):
    """The four tasks of the paper's appendix: (name, Task)."""
    t = np.linspace(0.0, 1.0, 96)
    chase = np.stack([-0.12 + 0.18 * np.cos(2 * np.pi * t), -0.46 + 0.06 * np.sin(4 * np.pi * t),
                      1.28 + 0.12 * np.sin(2 * np.pi * t)], 1)
    return [
        ("collision_free", Task("reach", np.array([[-0.28, -0.47, 1.14]]), HANGING, fps,
                                names=("over the crate",))),
        ("rotation", Task("sequence", np.array([[-0.30, -0.45, 1.30], [-0.70, -0.15, 1.35],
                                                 [-0.62, 0.35, 1.35]]), HANGING, fps,
                          names=("front", "side", "behind"))),
        ("guided", Task("guided", np.array([[-0.45, -0.44, 1.22]]), HANGING, fps,
                        names=("in the shelf",))),
        ("chase", Task("chase", chase, HANGING, fps, names=("moving ball",))),
    ]


def core_demo(out) -> int:
    """Plan the four tasks with the core alone and print Table 2 beside the paper's."""
    arm = standard_arm()
    planner = Planner(arm, obstacles(WORKPLACE), Settings())
    rows = []
    for name, task in demo_tasks():
        p = planner.plan(task)
        rows.append((name, p))
        print(f"{name:15s} {'ok' if p.success else 'FAILED: ' + p.message}", file=out)
    print(file=out)
    print(f"{'task':15s} {'search s':>9s} {'paper s':>8s} {'nodes':>6s} {'paper':>6s} "
          f"{'in sol.':>7s} {'paper':>6s} {'length':>7s} {'paper':>6s}", file=out)
    for name, p in rows:
        t, n, k, length = PAPER_TABLE2[name]
        s = p.stats
        print(f"{name:15s} {s.search_time_s:9.3f} {t:8.3f} {s.nodes_searched:6d} {n:6d} "
              f"{s.nodes_in_solution:7d} {k:6d} {s.path_length_arm_lengths:7.2f} {length:6.2f}",
              file=out)
    if planner.has_workspace:
        print(f"\nworkspace preprocessing: {planner.workspace.build_time_s:.3f} s "
              f"(paper: about 6 s)", file=out)
    return 0 if all(p.success for _n, p in rows) else 1


# --- the demo in Blender -------------------------------------------------------------------

#: The character: Quaternius' "Female Casual" (CC0, see tests/data/rigs/), with a skinned body.
DEMO_RIG = "Quaternius_Female_Casual.fbx"
COLOURS = {"Table": (0.55, 0.36, 0.2, 1), "Crate": (0.75, 0.6, 0.3, 1),
           "Shelf": (0.45, 0.47, 0.5, 1), "Floor": (0.8, 0.8, 0.78, 1),
           "Side Table": (0.5, 0.33, 0.2, 1)}
GAP = 12          # frames between tasks, in which the arm returns to its start pose
#: Frames in which the body stands up again after the whole-body task, before the step.
BODY_GAP = 36


def _rig_file():
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


def _empty(name, location, shape="SPHERE", size=0.025):
    import bpy

    ob = bpy.data.objects.new(name, None)
    ob.empty_display_type, ob.empty_display_size = shape, size
    ob.location = tuple(map(float, location))
    bpy.context.scene.collection.objects.link(ob)
    return ob


def build_scene():
    """An empty file with the demo character standing where the core's standard figure
    stands (facing −Y, chest at 1.40 m, scaled to the same arm length), the workplace
    furniture, a camera and a light. Returns the armature."""
    import bpy
    from mathutils import Matrix, Vector

    from .blender import rig as rig_mod
    from .samples import standard_arm

    bpy.ops.wm.read_homefile(use_empty=True)
    scene = bpy.context.scene
    bpy.ops.import_scene.fbx(filepath=str(_rig_file()))
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
    _arms_down(armature, rig_mod.build(armature, "right"))

    for name, parts in WORKPLACE.items():
        _box_object(name, parts, COLOURS[name])
    # the floor's top under her soles (scaled to the standard figure, they stand 5.5 cm
    # lower than its feet)
    top = _soles(armature)
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


def _soles(armature) -> float:
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


def _arms_down(armature, info):
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


def _keep_display(scene, task_name):
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


def _arm_rest(armature, bones):
    """The start pose of the bones a bake keys (chest and arm), to return to between
    tasks: each of the paper's tasks starts from the same standing pose."""
    return {b: armature.pose.bones[b].matrix_basis.copy() for b in bones}


def _key_rest(armature, rest, frame):
    for name, basis in rest.items():
        pb = armature.pose.bones[name]
        pb.matrix_basis = basis
        mode = pb.rotation_mode
        path = ("rotation_quaternion" if mode == "QUATERNION" else
                "rotation_axis_angle" if mode == "AXIS_ANGLE" else "rotation_euler")
        pb.keyframe_insert(path, frame=frame)
        pb.keyframe_insert("location", frame=frame)


def scene_demo(out_dir, render: bool = True, out=None) -> int:
    """``make demo``: the paper's four tasks on a real character in Blender, then a
    whole-body one (a cup on the floor beside her, Lean on: :data:`WHOLE_BODY_AT`), baked,
    saved to ``out_dir/demo.blend``, rendered (a still per task with the red trajectory, one MP4)
    unless ``render`` is off, reported (``report.json``) and compared with Table 2; progress
    lines to ``out`` (default stdout). Returns 0 if every task reached, else 1."""
    import sys
    import time
    from pathlib import Path

    import bpy

    from . import __version__
    from .blender import rig as rig_mod

    out = out or sys.stdout
    out_dir = Path(out_dir).resolve()
    out_dir.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    print(f"Reach {__version__} demo on Blender {bpy.app.version_string}: building the "
          "workplace around Quaternius' Female Casual (CC0)", file=out, flush=True)
    armature = build_scene()
    scene = bpy.context.scene
    frame = 1
    rows, reports, renders = [], [], {}
    bones = rig_mod.build(armature, "right").bones
    rest = _arm_rest(armature, {bones.keyed_chest, *(bones.arms["right"].keyed(role) for role in
                                                     ("clavicle", "upper_arm", "forearm", "hand"))}
                     - {None})
    standing = _arm_rest(armature, [pb.name for pb in armature.pose.bones])
    outcome = None
    for name, task in demo_tasks(fps=24.0):
        outcome, end, row, report = _demo_task(armature, name, task, frame, out)
        rows.append(row)
        reports.append(report)
        if render:
            from .blender.render import render_outcome

            renders[name] = render_outcome(bpy.context, outcome, out_dir, still=f"{name}.png",
                                           video=None)["still"]
            print(f"{'':15s} rendered {name}.png", file=out, flush=True)
        _keep_display(scene, name)
        _key_rest(armature, rest, end + GAP)
        frame = end + GAP + 1
    # the whole body: Lean on, a cup on the floor beside her (not in the paper's Table 2),
    # as high over it as her hand's and forearm's capsules let a wrist come
    model = rig_mod.build(armature, "right").arm
    above = max(WHOLE_BODY_ABOVE,
                max(model.hand_radius, model.forearm_radius) / model.arm_length + 0.03)
    floor = above * model.arm_length + _soles(armature)
    cup = Task("reach", np.array([[*WHOLE_BODY_AT, floor]]), HANGING, 24.0,
               names=("on the floor",))
    _outcome, end, body_ok = _body_task(armature, "whole_body", cup, frame, out, out_dir,
                                        render, renders, reports)
    # back to standing, then a step to her right, to the side table
    _stand_up(armature, standing, frame, end)
    frame = end + BODY_GAP + 1
    scene.frame_set(frame)
    _cut_to(scene.camera, STEP_CAMERA, frame)
    outcome, end, step_ok = _body_task(armature, "step", _step_target(armature), frame, out,
                                       out_dir, render, renders, reports)
    _finish(armature, outcome, end, out_dir, render, rows, reports, renders, t_start, out)
    return 0 if body_ok and step_ok and all(ok for _n, ok, _s in rows) else 1


def _body_task(armature, name, task, frame, out, out_dir, render, renders, reports):
    """Bake a whole-body task (Lean and Look at target on) from ``frame``, render its still
    (with ``render``), keep its display; returns (outcome, last frame, reached)."""
    import bpy

    outcome, end, (_n, ok, _s), report = _demo_task(
        armature, name, task, frame, out, Settings().replace(lean=True, gaze=True))
    reports.append(report)
    if render:
        from .blender.render import render_outcome

        renders[name] = render_outcome(bpy.context, outcome, out_dir, still=f"{name}.png",
                                       video=None)["still"]
        print(f"{'':15s} rendered {name}.png", file=out, flush=True)
    _keep_display(bpy.context.scene, name)
    return outcome, end, ok


def _keyed_bones(armature, first: int, last: int) -> list:
    """The bones Reach keyed on frames ``first``..``last`` (:mod:`.blender.own_keys`)."""
    from .blender import own_keys

    return sorted(own_keys.overlapping(armature, first, last))


def _cut_to(camera, view, frame: int) -> None:
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


def _stand_up(armature, standing, first: int, last: int) -> None:
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
    _key_rest(armature, moved, last + BODY_GAP)
    own_keys.record(armature.animation_data.action, _keyed_bones(armature, first, last),
                    last + 1, last + BODY_GAP)


def _same(a, b, tolerance: float = 1e-6) -> bool:
    return float(np.abs(np.array(a) - np.array(b)).max()) <= tolerance


def _step_target(armature):
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
    _box_object("Side Table", [((far, thing[1] - 0.25, _soles(armature)), (near, thing[1] + 0.25,
                                                                           top))],
                COLOURS["Side Table"])
    return Task("reach", thing[None], HANGING, 24.0, names=("on the side table",))


def _demo_target_names(task, frame) -> list:
    """The targets of ``task`` as objects in the scene: a ball keyed along a chase's path
    from ``frame`` on, else an Empty per target. Returns their names."""
    if task.kind == "chase":
        ball = _empty("Ball", task.targets[0], size=0.04)
        for i, p in enumerate(task.targets):
            ball.location = tuple(map(float, p))
            ball.keyframe_insert("location", frame=frame + i)
        return [ball.name]
    return [_empty(f"Target {label}", p).name for label, p in zip(task.names, task.targets)]


def _demo_task(armature, name, task, frame, out, settings=None):
    """Bake one of the demo's tasks from ``frame`` on with the right arm (and ``settings``,
    default the defaults) and print its line; returns (outcome, last frame, Table 2 row
    (name, ok, stats), report entry)."""
    import time

    import bpy

    from .blender import pipeline

    request = pipeline.Request(
        armature=armature.name, targets=_demo_target_names(task, frame), task=task.kind,
        side="right", frame_start=frame, show_guides=(name == "guided"),
        settings=settings or Settings())
    t0 = time.perf_counter()
    outcome = pipeline.run(bpy.context, request, bake=True)
    results = outcome.results
    end = max(r.frame_end for r in results)
    ok = all(r.success for r in results)
    print(f"{name:15s} {'reached' if ok else 'FAILED'}: frames {frame}-{end}, "
          f"{sum(r.stats['nodes_searched'] for r in results)} nodes, "
          f"{time.perf_counter() - t0:.1f} s" +
          ("" if ok else "; " + "; ".join(r.message for r in results if not r.success)),
          file=out, flush=True)
    stats = _demo_stats(results)
    chest = _chest_against_table1(armature, outcome, frame) if name == "rotation" else []
    for c in chest:
        print(f"{'':15s} chest at '{c['target']}': {c['chest_yaw_deg']:5.1f}° "
              f"(Table 1: {c['table1_deg']:5.1f}° at {c['direction_deg']:.0f}°, "
              f"{100 * c['table1_distance_m']:.0f} cm)", file=out, flush=True)
    report = {"task": name, "success": ok, "frame_start": frame, "frame_end": end,
              "targets": [r.to_dict() for r in results], **stats,
              **({"chest_vs_table1": chest} if chest else {})}
    return outcome, end, (name, ok, stats), report


def _demo_stats(results) -> dict:
    """A task's Table 2 statistics summed over its results, and the hand's: its largest
    turn in one frame (relative to the forearm, and in space) and its mean bend over the
    task's frames (degrees)."""
    stats = {k: sum(r.stats[k] for r in results) for k in
             ("search_time_s", "preprocess_time_s", "nodes_searched", "nodes_in_solution",
              "path_length_arm_lengths")}
    for k in ("max_wrist_turn_deg_per_frame", "max_hand_turn_deg_per_frame"):
        stats[k] = max(r.stats[k] for r in results)
    frames = sum(r.stats["frames"] for r in results)
    stats["mean_wrist_bend_deg"] = sum(r.stats["mean_wrist_bend_deg"] * r.stats["frames"]
                                       for r in results) / max(frames, 1)
    stats["max_wrist_bend_deg"] = max(r.stats["max_wrist_bend_deg"] for r in results)
    stats["chicken_wing_frames"] = sum(r.stats.get("chicken_wing_frames", 0) for r in results)
    stats["mean_f_r"] = sum(r.stats["mean_f_r"] * r.stats["frames"]
                            for r in results) / max(frames, 1)
    return stats


def _finish(armature, outcome, last, out_dir, render, rows, reports, renders, t_start, out):
    """Save ``demo.blend`` (frames 1..``last``), render the strip, the MP4 and the envelope
    (with ``render``), write ``report.json`` and print Table 2."""
    import json
    import time

    import bpy

    from . import __version__, atomic

    scene = bpy.context.scene
    scene.frame_start, scene.frame_end = 1, last
    scene.frame_set(1)
    blend = out_dir / "demo.blend"
    atomic.save_blend(blend)
    if render:
        from .blender.render import render_outcome

        renders["strip"] = _strip(out_dir, [r["task"] for r in reports], "demo-strip.png")
        print(f"{'':15s} joined the stills into demo-strip.png", file=out, flush=True)
        print(f"{'':15s} rendering demo.mp4 ({last} frames)", file=out, flush=True)
        renders["video"] = render_outcome(bpy.context, outcome, out_dir, still=None,
                                          video="demo.mp4", frames=(1, last),
                                          size=(480, 270))["video"]
        renders["envelope"] = _envelope_still(armature, out_dir, out)
    report = {"reach_version": __version__, "blender_version": bpy.app.version_string,
              "character": "Quaternius Female Casual (CC0)", "blend": str(blend),
              "tasks": reports, "renders": renders,
              "paper_table2": {k: dict(zip(("search_time_s", "nodes_searched",
                                            "nodes_in_solution", "path_length_arm_lengths"), v))
                               for k, v in PAPER_TABLE2.items()},
              "total_time_s": time.perf_counter() - t_start}
    atomic.write_text(out_dir / "report.json", json.dumps(report, indent=2))
    print(file=out)
    print(table2_text(rows), file=out)
    print(f"\nsaved {blend}, report.json" + (", stills and demo.mp4" if render else "") +
          f" in {out_dir} ({report['total_time_s']:.0f} s)", file=out, flush=True)


def _envelope_still(armature, out_dir, out) -> str:
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


def _strip(out_dir, names, filename, width=480, gap=6) -> str:
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


def _chest_against_table1(armature, outcome, frame_start):
    """For each reached target of a task: the chest's turn at arrival, read from the
    evaluated bones (:mod:`reach_addon.blender.measure`), beside Table 1's value at the
    wrist's direction and distance as Blender shows them."""
    import bpy

    from .blender import measure
    from .core.torso import chest_rotation_deg, table1_distance

    scene, info = bpy.context.scene, outcome.rig
    bones, side, settings = info.bones, info.side, outcome.request.settings
    scene.frame_set(frame_start)
    axes = measure.body_axes_of(armature, bones)
    reference = measure.bone_matrix(armature, bones.keyed_chest)
    out = []
    for r in outcome.results:
        if not r.success:
            continue
        scene.frame_set(r.frame_end)
        at = measure.arrival(armature, bones, side, axes, reference)
        direction = at["wrist_direction_deg"]
        distance = float(table1_distance(at["wrist_distance"], info.arm.arm_length,
                                         info.arm.hand_length, settings))
        out.append({"target": r.target, "direction_deg": direction,
                    "table1_distance_m": distance, "chest_yaw_deg": at["chest_yaw_deg"],
                    "table1_deg": float(chest_rotation_deg(direction, distance,
                                                           settings.chest_rotation_max))})
    return out


def table2_text(rows) -> str:
    """Table 2, ours beside the paper's: rows of (task, success, stats dict)."""
    lines = [f"{'task':15s} {'search ms':>9s} {'paper ms':>9s} {'speed-up':>8s} {'nodes':>6s} "
             f"{'paper':>6s} {'in sol.':>7s} {'paper':>6s} {'length':>7s} {'paper':>6s} "
             f"{'prep ms':>8s} {'wrist°/fr':>9s} {'hand°/fr':>8s} {'bend°':>6s} {'max°':>5s} "
             f"{'wings':>5s} {'f_R':>5s}"]
    for name, _ok, s in rows:
        t, n, k, length = PAPER_TABLE2[name]
        ms = 1000 * s["search_time_s"]
        lines.append(f"{name:15s} {ms:9.1f} {1000 * t:9.0f} {1000 * t / max(ms, 1e-9):7.0f}× "
                     f"{s['nodes_searched']:6d} {n:6d} {s['nodes_in_solution']:7d} {k:6d} "
                     f"{s['path_length_arm_lengths']:7.2f} {length:6.2f} "
                     f"{1000 * s['preprocess_time_s']:8.1f} "
                     f"{s.get('max_wrist_turn_deg_per_frame', 0.0):9.1f} "
                     f"{s.get('max_hand_turn_deg_per_frame', 0.0):8.1f} "
                     f"{s.get('mean_wrist_bend_deg', 0.0):6.1f} "
                     f"{s.get('max_wrist_bend_deg', 0.0):5.1f} "
                     f"{s.get('chicken_wing_frames', 0):5d} {s.get('mean_f_r', 0.0):5.2f}")
    lines.append("wrist°/fr: the hand's largest turn in one frame relative to the forearm (bound "
                 "15° at 24 fps); hand°/fr: its whole turn in space, the forearm's turn and roll "
                 "included (bound 15°); bend° / max°: the wrist's mean and largest bend from "
                 "the rig's rest alignment, measured on the baked bones; wings: frames with the "
                 "elbow lifted over a low hand (chicken wing); f_R: the mean strength level")
    return "\n".join(lines)
