"""Build the reach scene inside Blender and save it (run by a Blender binary or the bpy
module; the same code in both):

    blender --background --factory-startup --python build_scene.py -- RIG OUT.blend

A real rig from ``tests/data/rigs`` held still in its rest pose, a target in front of its
right shoulder and a plate across the straight path to it (``rigs.plate_scene``). Prints
one JSON line ``SCENE {...}`` with the object names and the rig's arm length.
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
    kind, out = argv
    mod = addon_utils.enable("reach_addon", default_set=False, handle_error=None) \
        if "reach_addon" not in bpy.context.preferences.addons else sys.modules["reach_addon"]
    arm = rigs.load(kind)
    rigs.rest_still(arm)
    info = mod.blender.rig.build(arm, "right")
    target, plate = rigs.plate_scene(info, arm)
    bpy.context.scene.frame_start = bpy.context.scene.frame_current = 1
    bpy.ops.wm.save_as_mainfile(filepath=str(Path(out).resolve()))
    print("SCENE " + json.dumps({"armature": arm.name, "target": target.name, "plate": plate.name,
                                 "arm_length": info.arm.arm_length,
                                 "blender": bpy.app.version_string}), flush=True)


if __name__ == "__main__":
    main(sys.argv[sys.argv.index("--") + 1:])
