"""Headless renders of a baked reach (Workbench): a still of the last frame with the red
trajectory, as in the paper's figures, and an MP4 of the motion.

Final renders do not draw armatures, so a figure without a skinned mesh gets temporary
stand-in rods on its bones; a scene without a camera gets a temporary one looking at the
reach from the front and the reaching side. Everything temporary is removed and every
render setting restored afterwards.
"""

from __future__ import annotations

from contextlib import contextmanager
from pathlib import Path

import bpy
import numpy as np
from mathutils import Matrix, Vector

from .. import atomic
from . import skin
from .scene import VIZ_TAG


def _skinned(armature, scene):
    """Does the figure show: a mesh the armature deforms, or rigid parts on its bones?"""
    return any(skin.deformed_by(ob, armature) or skin.rigid_part(ob, armature)
               for ob in scene.objects)


def _stand_ins(armature, scene, min_length):
    """Thin rods along the armature's bones, parented to them."""
    made = []
    mw = armature.matrix_world
    for bone in armature.data.bones:
        head, tail = mw @ bone.head_local, mw @ bone.tail_local
        length = (tail - head).length
        if length < min_length:
            continue
        bpy.ops.mesh.primitive_cylinder_add(vertices=8, radius=0.12 * length, depth=length)
        rod = bpy.context.object
        rod.name = f"Reach Stand-in {bone.name}"
        rod[VIZ_TAG] = True
        direction = (tail - head).normalized()
        rod.matrix_world = Matrix.Translation((head + tail) / 2) @ \
            direction.to_track_quat("Z", "Y").to_matrix().to_4x4()
        world = rod.matrix_world.copy()
        rod.parent = armature
        rod.parent_type = "BONE"
        rod.parent_bone = bone.name
        rod.matrix_world = world
        made.append(rod)
    return made


def _framed_points(outcome):
    """The points a still of ``outcome`` frames: the targets and the trajectories."""
    points = []
    for plan, _first in outcome.plans:
        points += list(plan.wrist_trajectory()) + list(plan.task.targets)
    return points


def _camera(scene, info, points, fit: bool = False):
    """A camera that frames the shoulder, the body's origin and ``points`` (world): close
    (3.2 radii of their bounding sphere), or, with ``fit``, the whole sphere within the
    picture's height (a 16:9 frame at 35 mm)."""
    f, length = info.frame, info.arm.arm_length
    side = f.right if info.side == "right" else -f.right
    pts = np.array([info.joints_world["shoulder"], info.frame.origin] + list(points))
    centre = pts.mean(0)
    radius = max(float(np.linalg.norm(pts - centre, axis=1).max()), 0.5 * length)
    # from the front and the reaching side; with ``fit`` from that side, a little from the
    # front and above (furniture in front of the character would hide a whole envelope)
    view = (0.5 * f.forward + 2.0 * side + 0.9 * f.up) if fit else \
        (2.0 * f.forward + 1.3 * side + 0.6 * f.up)
    view /= np.linalg.norm(view)
    cam_data = bpy.data.cameras.new("Reach Camera")
    cam_data.lens = 35
    cam = bpy.data.objects.new("Reach Camera", cam_data)
    cam[VIZ_TAG] = True
    scene.collection.objects.link(cam)
    distance = 4.4 * radius if fit else 3.2 * radius
    cam.location = Vector(centre + view * distance)
    cam.rotation_euler = (Vector(centre) - cam.location).to_track_quat("-Z", "Y").to_euler()
    cam_data.clip_end = 20 * distance
    return cam


def render_outcome(context, outcome, folder: Path, still: str | None = "last_frame.png",
                   video: str | None = "reach.mp4", frames=None, size=(640, 360)) -> dict:
    """Render the baked frames of ``outcome`` into ``folder``: a still of the last frame
    and a video of ``frames`` (first, last; default the outcome's own). A name of None
    skips that file. Returns {"still": path, "video": path} of what was written. Each file
    is rendered to a temporary name in ``folder`` and renamed into place when complete
    (:mod:`reach_addon.atomic`)."""
    folder = Path(folder).resolve()
    folder.mkdir(parents=True, exist_ok=True)
    first = min(r.frame_start for r in outcome.results)
    last = max(r.frame_end for r in outcome.results)
    if frames is not None:
        first, last = frames
    with _rendering(context, outcome.rig, _framed_points(outcome), size) as r:
        written = {}
        if still:
            context.scene.frame_set(last)
            written["still"] = str(folder / still)
            _write_still(r, written["still"])
        if video:
            written["video"] = str(folder / video)
            _set_format(r, "FFMPEG")
            r.ffmpeg.format = "MPEG4"
            r.ffmpeg.codec = "H264"
            context.scene.frame_start, context.scene.frame_end = first, last
            with atomic.replacing(written["video"]) as tmp:
                r.filepath = str(tmp)
                bpy.ops.render.render(animation=True)
        return written


def render_still(context, info, points, path, size=(640, 360)) -> str:
    """A still of the current frame into ``path`` (PNG) from a camera of its own that
    frames the character of ``info`` and ``points`` (world), e.g. the reach envelope, whole
    (the scene's camera is left as it is)."""
    path = Path(path).resolve()
    path.parent.mkdir(parents=True, exist_ok=True)
    with _rendering(context, info, points, size, fit=True) as r:
        _write_still(r, str(path))
    return str(path)


def _write_still(r, path):
    _set_format(r, "PNG")
    with atomic.replacing(path) as tmp:
        r.filepath = str(tmp)
        bpy.ops.render.render(write_still=True)


@contextmanager
def _rendering(context, info, points, size, fit=False):
    """Workbench set up for Reach's renders (stand-ins, a camera framing ``points`` where the
    scene has none, material colours, ``size``); yields the render settings and restores
    everything afterwards."""
    scene = context.scene
    armature = bpy.data.objects[info.armature_name]
    r = scene.render
    saved = {"engine": r.engine, "filepath": r.filepath, "x": r.resolution_x,
             "y": r.resolution_y, "pct": r.resolution_percentage, "start": scene.frame_start,
             "end": scene.frame_end, "camera": scene.camera, "frame": scene.frame_current,
             "format": r.image_settings.file_format,
             "media": getattr(r.image_settings, "media_type", None),
             "color": scene.display.shading.color_type}
    temporaries = []
    try:
        if not _skinned(armature, scene):
            temporaries += _stand_ins(armature, scene, 0.08 * info.arm.arm_length)
        if scene.camera is None or fit:
            scene.camera = _camera(scene, info, points, fit)
            temporaries.append(scene.camera)
        r.engine = "BLENDER_WORKBENCH"
        scene.display.shading.color_type = "MATERIAL"
        r.resolution_x, r.resolution_y, r.resolution_percentage = *size, 100
        yield r
    finally:
        for ob in temporaries:
            kind, data = ob.type, ob.data.name if ob.data else None
            bpy.data.objects.remove(ob, do_unlink=True)
            coll = bpy.data.meshes if kind == "MESH" else bpy.data.cameras
            if data in coll and coll[data].users == 0:
                coll.remove(coll[data])
        r.engine, r.filepath = saved["engine"], saved["filepath"]
        r.resolution_x, r.resolution_y, r.resolution_percentage = saved["x"], saved["y"], saved["pct"]
        scene.frame_start, scene.frame_end = saved["start"], saved["end"]
        scene.camera = saved["camera"]
        scene.display.shading.color_type = saved["color"]
        if saved["media"] is not None:
            r.image_settings.media_type = saved["media"]
        r.image_settings.file_format = saved["format"]
        scene.frame_set(saved["frame"])


def _set_format(render, file_format):
    settings = render.image_settings
    if hasattr(settings, "media_type"):          # Blender 5.0+
        settings.media_type = "VIDEO" if file_format == "FFMPEG" else "IMAGE"
    settings.file_format = file_format
