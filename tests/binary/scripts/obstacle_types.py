"""Build the every-object-type scene round a real rig, gather Reach's obstacles from it
several times, and save it (run by a Blender binary or the bpy module; the same code):

    blender --background --factory-startup --python obstacle_types.py -- RIG OUT.blend
    python obstacle_types.py RIG OUT.blend                     (bpy module, Reach importable)

Prints one JSON line ``OBSTACLES {...}``: what was made (name → Blender type), Reach's
(name, triangles) per obstacle on each gather, the live cache's signature entries, the
triangles each object shows read independently of Reach, and a free target "Cup" in front
of the right shoulder for a bake.
"""

import json
import sys
from pathlib import Path

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "blender"))   # tests/blender: rigs, obstacle_scene

import bpy  # noqa: E402
import obstacle_scene  # noqa: E402
import rigs  # noqa: E402

GATHERS = 4


def main(argv):
    kind, out = argv
    from reach_addon.blender import rig as rig_mod
    from reach_addon.blender import scene as scene_mod
    from reach_addon.blender.scene import ObstacleCache

    arm = rigs.load(kind)
    rigs.rest_still(arm)
    info = rig_mod.build(arm, "right")
    made = obstacle_scene.every_type(info)
    f, length = info.frame, info.arm.arm_length
    cup = rigs.add_target("Cup", info.joints_world["shoulder"] + length * (0.6 * f.forward + 0.1 * f.up))
    context = bpy.context
    exclude = scene_mod.character_objects(arm, context.scene) | {cup.name}
    runs = []
    for _ in range(GATHERS):
        runs.append(scene_mod.gather_obstacles(context, exclude).triangle_counts())
        context.view_layer.update()
    cache = ObstacleCache(exclude)
    signature = [list(e[:2]) for e in cache.compute_signature(context, geometry=True)]
    independent = {name: len(obstacle_scene.evaluated_triangles(bpy.data.objects[name]))
                   for name in made}
    context.scene.frame_start = context.scene.frame_current = 1
    bpy.ops.wm.save_as_mainfile(filepath=str(Path(out).resolve()))
    print("OBSTACLES " + json.dumps({
        "blender": bpy.app.version_string, "armature": arm.name, "target": cup.name,
        "arm_length": length, "made": made, "runs": runs, "signature": signature,
        "independent": independent}), flush=True)


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:])
    if not bpy.app.binary_path:
        # bpy 4.2/4.5 as a module crash at Python's shutdown once Rigify's properties were
        # registered (reach_addon.compat); everything is printed and saved by now.
        from reach_addon.compat import exit_module_blender

        exit_module_blender(0)
