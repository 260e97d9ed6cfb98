"""Table 1 on baked motion: bake reaches over directions and read the chest's turn back.

:func:`sweep` bakes one reach per (Table 1 row, direction) on an armature of the current
scene, each from the same start pose, and reads back from Blender's evaluated bones
(:mod:`reach_addon.blender.measure`, no planner code) the wrist's direction (degrees from
straight ahead toward the reaching side) and distance from the spine axis (world units),
and the chest's turn about the vertical at arrival (degrees). Targets are placed in the
figure's own body frame at the wrist distance that maps to each row (Table 1's reach
distance is measured to the hand and scaled by arm length: :mod:`reach_addon.core.torso`).
``tests/blender/test_table1.py`` holds the points to the paper's table; ``bench/table1.py``
plots them.
"""

from __future__ import annotations

#: Directions of the sweep (degrees from straight ahead toward the reaching side).
DIRECTIONS = tuple(range(30, 166, 15))
#: Table 1's rows (m).
ROWS = (0.75, 0.85)
#: Height of the targets below the shoulders, in arm lengths.
DROP = 0.15


def sweep(context, armature, package, directions=DIRECTIONS, rows=ROWS, side="right",
          settings=None, drop=DROP):
    """Bake a reach to each (row in metres, direction in degrees) from frame 1 and measure
    the arrival (the module docstring); the armature is put back as it was. ``package`` is
    the add-on's package (``reach_addon``, or the installed extension's in the tests);
    ``drop``: the targets' height below the shoulder, arm lengths. Returns one dict per
    reach: ``row_m``, ``direction_deg``, ``success``, ``reason``, ``arm_length`` and
    ``hand_length`` (world units), ``wrist_direction_deg``, ``wrist_distance`` (world
    units), ``table1_distance_m`` (the distance Table 1 reads), ``target_error`` (arm
    lengths) and ``chest_yaw_deg``."""
    import importlib

    import bpy

    def module(name):
        return importlib.import_module(f"{package.__name__}.{name}")

    measure, pipeline, rig = (module(f"blender.{m}") for m in ("measure", "pipeline", "rig"))
    table1_distance = module("core.torso").table1_distance
    settings = settings or module("core").Settings()
    scene = context.scene
    scene.frame_set(1)
    info = rig.build(armature, side)
    bones, arm = info.bones, info.arm
    axes = measure.body_axes_of(armature, bones)
    reference = measure.bone_matrix(armature, bones.keyed_chest)
    start = {pb.name: pb.matrix_basis.copy() for pb in armature.pose.bones}
    # the wrist's distance from the spine axis that reads a row (table1_distance inverted)
    scale = settings.table1_arm_length_m / arm.arm_length
    wrist_distance = {row: row / scale - settings.table1_hand_point * arm.hand_length
                      for row in rows}
    out = []
    for row in rows:
        for direction in directions:
            armature.animation_data_clear()
            for pb in armature.pose.bones:
                pb.matrix_basis = start[pb.name]
            scene.frame_set(1)
            target = bpy.data.objects.new(f"Table1 {row} {direction}", None)
            target.location = axes.point(direction, wrist_distance[row],
                                         -drop * arm.arm_length, side)
            scene.collection.objects.link(target)
            request = pipeline.Request(armature=armature.name, targets=[target.name],
                                       task="reach", side=side, frame_start=1,
                                       settings=settings, draw=False)
            result = pipeline.run(context, request, bake=True).results[0]
            scene.frame_set(result.frame_end)
            at = measure.arrival(armature, bones, side, axes, reference)
            out.append({
                "row_m": row, "direction_deg": float(direction), "success": result.success,
                "arm_length": arm.arm_length, "hand_length": arm.hand_length,
                "reason": result.reason,
                "wrist_direction_deg": at["wrist_direction_deg"],
                "wrist_distance": at["wrist_distance"],
                "table1_distance_m": float(table1_distance(at["wrist_distance"], arm.arm_length,
                                                           arm.hand_length, settings)),
                "target_error": (at["wrist"] - target.location).length / arm.arm_length,
                "chest_yaw_deg": at["chest_yaw_deg"],
            })
            bpy.data.objects.remove(target)
    armature.animation_data_clear()
    for pb in armature.pose.bones:
        pb.matrix_basis = start[pb.name]
    scene.frame_set(1)
    return out
