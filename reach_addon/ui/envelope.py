"""The Envelope sub-panel: compute the reach envelope (:mod:`reach_addon.core.envelope`) of
the panel's armature and arm, draw it over the viewport, and optionally write it as a mesh.

* **Compute** (``reach.envelope``) runs :func:`~reach_addon.blender.pipeline.envelope_steps`
  like Plan runs the planner: modal, in slices of about 30 ms, with progress in the panel,
  Esc to cancel (nothing changes); synchronous in background mode. An envelope still
  current (:func:`~reach_addon.blender.envelope.cached`: same pose, scene and settings) is
  not computed again. *As mesh* also writes it into the "Reach" collection
  (:func:`~reach_addon.blender.envelope.write_mesh`), so it renders and exports.
* **The overlay** draws each point that is not out of reach as a dot in its class's colour
  (Blender's ``gpu`` module, a ``POST_VIEW`` draw handler of the 3D View), with a toggle
  and a point size; the legend lists the classes with their counts. While the scene no
  longer matches the envelope (the pose, the obstacles or the settings changed), the panel
  says it is out of date.
"""

from __future__ import annotations

import time

import bpy
import gpu
import numpy as np
from gpu_extras.batch import batch_for_shader

from ..blender import envelope as envelope_mod
from ..blender import pipeline
from ..core.envelope import CLASSES, COLOURS, LABELS, OUT
from ..core.settings import fields
from .operators import _poll, _Run
from .properties import request_from

_handle = None
_batches: dict = {}          # scene name -> (outcome, batch): the overlay's GPU batch
_checked: dict = {}          # scene name -> (outcome, when, still current?): see _current
_point_shader = None
#: Seconds the panel keeps its answer to "is the envelope still current?".
RECHECK_S = 0.5


def _redraw(_self=None, context=None):
    screen = getattr(context, "screen", None) if context else None
    for area in screen.areas if screen else ():
        if area.type == "VIEW_3D":
            area.tag_redraw()


def _colour(k):
    return bpy.props.FloatVectorProperty(
        name=LABELS[k], subtype="COLOR", size=4, min=0.0, max=1.0, default=COLOURS[k],
        update=_recolour, description=f"Colour of the points of class '{CLASSES[k]}'")


def _recolour(self, context):
    _batches.clear()
    _redraw(context=context)


def colours(ui) -> list:
    """The display colours of the classes (RGBA), as set in the panel; out of reach last."""
    return [tuple(getattr(ui, f"colour_{k}")) for k in range(OUT)] + [COLOURS[OUT]]


class REACH_PG_envelope(bpy.types.PropertyGroup):
    show: bpy.props.BoolProperty(name="Show", default=True, update=_redraw,
                                 description="Draw the envelope's points over the viewport")
    point_size: bpy.props.FloatProperty(name="Point Size", default=6.0, min=1.0, max=30.0,
                                        update=_redraw, description="Size of the overlay's dots "
                                        "in pixels")
    as_mesh: bpy.props.BoolProperty(name="As Mesh", default=False,
                                    description="Also write the envelope as a mesh in the Reach "
                                    "collection (class materials and point colours), so it "
                                    "renders and exports")
    colour_0: _colour(0)
    colour_1: _colour(1)
    colour_2: _colour(2)
    colour_3: _colour(3)
    colour_4: _colour(4)
    colour_5: _colour(5)
    colour_6: _colour(6)
    colour_7: _colour(7)


class REACH_OT_envelope(_Run, bpy.types.Operator):
    """Compute the arm's reach envelope on a grid and show it in the viewport"""

    bl_idname = "reach.envelope"
    bl_label = "Compute Reach Envelope"
    bl_options = {"REGISTER"}
    cancelled = "Reach envelope cancelled"

    @classmethod
    def poll(cls, context):
        return _poll(cls, context, need_target=False)

    def steps(self, context):
        return _steps(context, request_from(context.scene.reach))

    def _finish(self, context, outcome):
        ui = context.scene.reach_envelope
        env = outcome.envelope
        counts = env.counts()
        ui.show = True
        context.scene.reach.status = ""
        if ui.as_mesh:
            envelope_mod.write_mesh(context, outcome, colours(ui))
        _redraw(context=context)
        self.report({"INFO"}, f"Reach envelope of {outcome.rig.armature_name} "
                              f"({outcome.rig.side} arm): {len(env.classes)} points, "
                              f"{len(env.classes) - counts['out']} within reach or blocked")
        return {"FINISHED"}


def _steps(context, request):
    """The envelope's steps: the cached envelope if it is still current, else the
    pipeline's, stored in the cache when done."""
    current = envelope_mod.cached(context, request)
    if current is not None:
        return current
    key = envelope_mod.state_key(context, request)
    outcome = yield from pipeline.envelope_steps(context, request)
    envelope_mod.store(context, outcome, key)
    return outcome


class REACH_OT_envelope_clear(bpy.types.Operator):
    """Forget the reach envelope and remove its mesh"""

    bl_idname = "reach.envelope_clear"
    bl_label = "Clear Reach Envelope"
    bl_options = {"REGISTER", "UNDO"}

    def execute(self, context):
        envelope_mod.forget(context.scene)
        envelope_mod.viz.remove(envelope_mod.MESH_NAME)
        _redraw(context=context)
        return {"FINISHED"}


class REACH_PT_envelope(bpy.types.Panel):
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "Reach"
    bl_label = "Envelope"
    bl_parent_id = "REACH_PT_main"
    bl_options = {"DEFAULT_CLOSED"}

    def draw(self, context):
        layout = self.layout
        ui = context.scene.reach_envelope
        settings = context.scene.reach.settings
        col = layout.column()
        col.use_property_split = True
        col.use_property_decorate = False
        for f in fields():
            if f.metadata["group"] == "envelope":
                col.prop(settings, f.name)
        col.prop(ui, "as_mesh")
        row = layout.row(align=True)
        row.scale_y = 1.2
        row.operator("reach.envelope", text="Compute", icon="SPHERE")
        row.operator("reach.envelope_clear", text="", icon="X")
        row = layout.row(align=True)
        row.prop(ui, "show", text="", icon="HIDE_OFF" if ui.show else "HIDE_ON")
        row.prop(ui, "point_size", text="Size")
        outcome = envelope_mod.last(context.scene)
        if outcome is None:
            return
        counts = outcome.envelope.counts()
        if not _current(context, outcome):
            layout.label(text="Out of date: compute again", icon="ERROR")
        legend = layout.column(align=True)
        for k, label in enumerate(LABELS):
            row = legend.row(align=True)
            split = row.split(factor=0.2, align=True)
            if k != OUT:
                split.prop(ui, f"colour_{k}", text="")
            else:
                split.label(text="", icon="BLANK1")
            split.label(text=f"{label}: {counts[CLASSES[k]]}")


def _current(context, outcome) -> bool:
    """Whether ``outcome`` is still the envelope of the scene as it is. The check reads
    every obstacle's matrix (:func:`~reach_addon.blender.envelope.state_key`), too much for
    every redraw of the sidebar in a big scene, so its answer is kept for
    :data:`RECHECK_S` seconds."""
    now = time.monotonic()
    seen = _checked.get(context.scene.name)
    if seen is None or seen[0] is not outcome or now - seen[1] > RECHECK_S:
        fresh = envelope_mod.cached(context, request_from(context.scene.reach)) is outcome
        seen = _checked[context.scene.name] = (outcome, now, fresh)
    return seen[2]


def _shader():
    """The overlay's shader: flat colours per point, by the name this Blender has."""
    global _point_shader
    if _point_shader is None:
        for name in ("POINT_FLAT_COLOR", "FLAT_COLOR", "3D_FLAT_COLOR"):
            try:
                _point_shader = gpu.shader.from_builtin(name)
                break
            except (ValueError, TypeError):
                continue
        else:
            raise RuntimeError("no flat-colour shader in this Blender")
    return _point_shader


def _draw():
    context = bpy.context
    scene = context.scene
    ui = getattr(scene, "reach_envelope", None)
    if ui is None or not ui.show:
        return
    outcome = envelope_mod.last(scene)
    if outcome is None:
        return
    shader = _shader()
    entry = _batches.get(scene.name)
    if entry is None or entry[0] is not outcome:
        points, classes = envelope_mod.drawn(outcome)
        table = colours(ui)
        rgba = np.array([table[c] for c in classes], np.float32).reshape(-1, 4)
        batch = batch_for_shader(shader, "POINTS", {"pos": points.astype(np.float32).tolist(),
                                                   "color": rgba.tolist()})
        entry = _batches[scene.name] = (outcome, batch)
    gpu.state.point_size_set(ui.point_size)
    gpu.state.depth_test_set("LESS_EQUAL")
    gpu.state.blend_set("ALPHA")
    entry[1].draw(shader)
    gpu.state.depth_test_set("NONE")
    gpu.state.blend_set("NONE")
    gpu.state.point_size_set(1.0)


def register_properties():
    global _handle
    bpy.types.Scene.reach_envelope = bpy.props.PointerProperty(type=REACH_PG_envelope)
    if _handle is None and not bpy.app.background:
        _handle = bpy.types.SpaceView3D.draw_handler_add(_draw, (), "WINDOW", "POST_VIEW")


def unregister_properties():
    global _handle
    if _handle is not None:
        bpy.types.SpaceView3D.draw_handler_remove(_handle, "WINDOW")
        _handle = None
    _batches.clear()
    _checked.clear()
    del bpy.types.Scene.reach_envelope


property_groups = (REACH_PG_envelope,)
classes = (REACH_OT_envelope, REACH_OT_envelope_clear, REACH_PT_envelope)
