"""Dump what a bake left in a .blend, in any Blender host (binary or bpy module):

    blender --background OUT.blend --python dump_keys.py -- OUT.blend DUMP.json ARMATURE
    python dump_keys.py OUT.blend DUMP.json ARMATURE            (bpy module)

Writes ``{"blender", "action", "frame_range", "keys", "heads", "target"}``: every F-curve
key of the armature's action as ``"data_path[index]" -> [[frame, value], ...]`` (read
through ``Action.fcurves`` before slotted actions, through layers/strips/channelbags after),
and the world-space heads of every pose bone at each keyed frame, evaluated by Blender.
"""

import json
import sys
from pathlib import Path


def curves(action):
    if hasattr(action, "layers"):                      # slotted actions (4.4+)
        return [fc for layer in action.layers for strip in layer.strips
                for bag in strip.channelbags for fc in bag.fcurves]
    return list(action.fcurves)


def main(blend, out, armature):
    import bpy

    if Path(bpy.data.filepath or ".").resolve() != Path(blend).resolve():
        bpy.ops.wm.open_mainfile(filepath=str(Path(blend).resolve()), load_ui=False)
    scene = bpy.context.scene
    arm = bpy.data.objects[armature]
    action = arm.animation_data.action if arm.animation_data else None
    keys = {}
    frames = set()
    for fc in curves(action) if action else ():
        pts = [[k.co[0], k.co[1]] for k in fc.keyframe_points]
        keys[f"{fc.data_path}[{fc.array_index}]"] = pts
        frames.update(int(round(p[0])) for p in pts)
    heads = {}
    mw = arm.matrix_world
    for f in sorted(frames):
        scene.frame_set(f)
        heads[f] = {pb.name: list(mw @ pb.head) for pb in arm.pose.bones}
    data = {"blender": bpy.app.version_string, "action": action.name if action else None,
            "frame_range": [min(frames), max(frames)] if frames else None,
            "keys": keys, "heads": heads,
            "objects": {ob.name: list(ob.matrix_world.translation) for ob in scene.objects}}
    Path(out).write_text(json.dumps(data))


if __name__ == "__main__":
    args = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else sys.argv[1:]
    main(*args)
