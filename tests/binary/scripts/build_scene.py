"""Build the reach scene inside Blender and save it (run by a Blender binary or the bpy
module; the same code in both):

    blender --background --factory-startup --python build_scene.py -- RIG OUT.blend [small]

A real rig from ``tests/data/rigs`` held still in its rest pose, a target in front of its
right shoulder and a plate across the straight path to it (``rigs.plate_scene``). With
``small``, the character is made 0.2 m tall as a Mixamo import is small (armature scale
0.0012, ``rigs.small_scale``) first. Prints one JSON line ``SCENE {...}`` with the object
names, the rig's arm length and its height.
"""

import json
import sys
from pathlib import Path

import addon_utils
import bpy

HERE = Path(__file__).resolve().parent
sys.path.insert(0, str(HERE.parents[1] / "blender"))   # tests/blender/rigs.py

import rigs  # noqa: E402


def main(argv):
    kind, out, *small = argv
    mod = addon_utils.enable("reach_addon", default_set=False, handle_error=None) \
        if "reach_addon" not in bpy.context.preferences.addons else sys.modules["reach_addon"]
    arm = rigs.load(kind)
    rigs.rest_still(arm)
    if small == ["small"]:
        rigs.small_scale(arm)
    info = mod.blender.rig.build(arm, "right")
    target, plate = rigs.plate_scene(info, arm)
    if small == ["small"]:
        target.empty_display_size = 0.08 * info.arm.arm_length    # not 2 cm across a 20 cm figure
    bpy.context.scene.frame_start = bpy.context.scene.frame_current = 1
    bpy.ops.wm.save_as_mainfile(filepath=str(Path(out).resolve()))
    print("SCENE " + json.dumps({"armature": arm.name, "target": target.name, "plate": plate.name,
                                 "arm_length": info.arm.arm_length,
                                 "height": rigs.height(arm), "scale": arm.scale[0],
                                 "blender": bpy.app.version_string}), flush=True)


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:])
