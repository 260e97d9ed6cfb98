"""Render frames of baked .blend files through their scene camera, one row per file, as
one PNG: how the README's before/after pictures are made.

    .venv/bin/python tools/render_frames.py --out docs/elbow-before-after.png \
        --row before/demo.blend 85,88,91,94,97,100 --row out/demo.blend 91,95,99,103,107,111

Workbench (studio light, material colours, shadows) at ``--width`` pixels a frame: quick
and headless, no GPU. The camera, frame and scene are the file's own (``--view AXIS``: a
camera of its own instead, looking along the world axis at every mesh's bounds at the
first frame, for a test's bake that has none); nothing is saved back to the file.

    .venv/bin/python tools/render_frames.py --out docs/lean-hips-back.png --view +x \
        --row out/lean-test/far-quaternius.blend 1,24,69 --width 500 --crop 0.2,0,0.75,1
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path

import bpy
import numpy as np


#: The world axes ``--view`` looks along.
VIEWS = {"+x": (1, 0, 0), "-x": (-1, 0, 0), "+y": (0, 1, 0), "-y": (0, -1, 0)}


def view_camera(scene, axis: str, frame: int) -> None:
    """Make ``scene``'s camera one looking along the world ``axis`` (:data:`VIEWS`) at the
    bounds of every mesh at ``frame``, from 1.6 times their size away (35 mm lens)."""
    from mathutils import Vector

    scene.frame_set(frame)
    corners = np.array([tuple(ob.matrix_world @ Vector(c)) for ob in scene.objects
                        if ob.type == "MESH" for c in ob.bound_box])
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    centre = Vector(tuple(0.5 * (lo + hi)))
    cam = bpy.data.objects.new("render_frames view", bpy.data.cameras.new("render_frames view"))
    scene.collection.objects.link(cam)
    cam.location = centre - Vector(VIEWS[axis]) * 1.6 * float((hi - lo).max())
    cam.rotation_euler = (centre - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam.data.lens = 35.0
    scene.camera = cam


def render_row(blend: str, frames: list, width: int, tmp: Path, crop=None, view=None) -> list:
    """The frames of ``blend`` rendered through its scene camera, or ``view``'s
    (:func:`view_camera`) (``crop``: the part of the camera's frame kept, (x0, y0, x1, y1)
    in shares from the bottom left), each an (h, w, 4) array on white."""
    bpy.ops.wm.open_mainfile(filepath=blend, load_ui=False)
    scene = bpy.context.scene
    if view is not None:
        view_camera(scene, view, frames[0])
    if scene.camera is None:
        sys.exit(f"render_frames: {blend} has no scene camera; add one and save the file, "
                 "or give --view")
    r = scene.render
    r.engine = "BLENDER_WORKBENCH"
    scene.display.shading.light = "STUDIO"
    scene.display.shading.color_type = "MATERIAL"
    scene.display.shading.show_shadows = True
    r.film_transparent = True
    x0, y0, x1, y1 = crop or (0.0, 0.0, 1.0, 1.0)
    r.resolution_percentage = 100
    r.resolution_y = round(r.resolution_y * width / r.resolution_x / (x1 - x0))
    r.resolution_x = round(width / (x1 - x0))
    r.use_border = r.use_crop_to_border = crop is not None
    r.border_min_x, r.border_min_y, r.border_max_x, r.border_max_y = x0, y0, x1, y1
    r.image_settings.file_format = "PNG"
    tiles = []
    for f in frames:
        scene.frame_set(f)
        path = tmp / f"frame-{len(tiles)}.png"
        r.filepath = str(path)
        bpy.ops.render.render(write_still=True)
        img = bpy.data.images.load(str(path))
        px = np.empty(img.size[0] * img.size[1] * 4, np.float32)
        img.pixels.foreach_get(px)
        px = px.reshape(img.size[1], img.size[0], 4)
        alpha = px[..., 3:4]
        px[..., :3] = px[..., :3] * alpha + (1.0 - alpha)        # over white
        px[..., 3] = 1.0
        tiles.append(px)
        bpy.data.images.remove(img)
    return tiles


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--row", nargs=2, action="append", required=True,
                    metavar=("BLEND", "FRAMES"), help="a .blend and its frames, e.g. 85,90")
    ap.add_argument("--out", required=True)
    ap.add_argument("--width", type=int, default=280)
    ap.add_argument("--gap", type=int, default=4)
    ap.add_argument("--crop", help="x0,y0,x1,y1: the part of the camera's frame kept, in "
                    "shares from the bottom left")
    ap.add_argument("--view", choices=sorted(VIEWS),
                    help="a camera of its own, looking along this world axis")
    a = ap.parse_args(argv)
    crop = None if a.crop is None else tuple(float(v) for v in a.crop.split(","))
    with tempfile.TemporaryDirectory() as tmp:
        rows = [render_row(str(Path(b).resolve()), [int(f) for f in frames.split(",")],
                           a.width, Path(tmp), crop, a.view) for b, frames in a.row]
    h = max(t.shape[0] for row in rows for t in row)
    cols = max(len(row) for row in rows)
    w = a.width
    sheet = np.ones((len(rows) * (h + a.gap) - a.gap, cols * (w + a.gap) - a.gap, 4),
                    np.float32)
    for i, row in enumerate(rows):       # Blender's pixels run bottom up: first row on top
        y = (len(rows) - 1 - i) * (h + a.gap)
        for k, tile in enumerate(row):
            sheet[y:y + tile.shape[0], k * (w + a.gap):k * (w + a.gap) + tile.shape[1]] = tile
    img = bpy.data.images.new("frames", sheet.shape[1], sheet.shape[0], alpha=False)
    img.pixels.foreach_set(sheet.ravel())
    img.filepath_raw = str(Path(a.out).resolve())
    img.file_format = "PNG"
    img.save()
    print(f"wrote {a.out}: {len(rows)} rows of {cols} frames")
    return 0


if __name__ == "__main__":
    sys.exit(main())
