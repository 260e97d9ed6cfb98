"""Presets through Blender's preset system: strength, body (joint limits and body
rotation), rig maps (bone names) and orientation (which target axes the fingers and the
palm follow, for *Match orientation*).

Bundled presets live in the top-level ``presets/reach/<kind>/`` folder of the source tree,
staged into the extension as ``reach_addon/presets/`` by ``make dist``; users' own presets
go to Blender's user scripts folder, as with every Blender preset. A preset file is the
usual Python snippet that sets properties of ``bpy.context.scene.reach``.
"""

from __future__ import annotations

from pathlib import Path

import bpy
from bl_operators.presets import AddPresetBase

from ..core.settings import fields
from .properties import OVERRIDES

KINDS = {
    "strength": ("settings", [f.name for f in fields() if f.metadata["group"] == "strength"]),
    "body": ("settings", [f.name for f in fields()
                          if f.metadata["group"] in ("limits", "body", "step")]),
    "rigs": ("", ["use_overrides"] + OVERRIDES),
    "orientation": ("settings", [f.name for f in fields() if f.metadata["group"] == "orientation"]),
}


# Blender < 4.2 has no preset-path registry (``bpy.utils.register_preset_path``): there the
# bundled folder is added to the search here, for the lookup and for the menus.
_HAS_REGISTRY = hasattr(bpy.utils, "register_preset_path")


def subdir(kind: str) -> str:
    return f"reach/{kind}"


def preset_root() -> Path | None:
    """The folder holding ``presets/`` for this installation: the package itself when
    staged as an extension, the source tree's top level in a checkout."""
    here = Path(__file__).resolve().parent.parent
    for root in (here, here.parent):
        if (root / "presets" / "reach").is_dir():
            return root
    return None


def preset_files(kind: str) -> dict:
    """{preset name: path} of every preset of ``kind`` Blender can see (bundled and user)."""
    out = {}
    for folder in preset_dirs(subdir(kind)):
        for path in sorted(Path(folder).glob("*.py")):
            out[bpy.path.display_name(path.stem)] = path
    return out


def preset_dirs(sub: str) -> list:
    """Blender's preset folders for ``sub`` (e.g. ``reach/strength``), plus the bundled one
    on Blender < 4.2."""
    dirs = bpy.utils.preset_paths(sub)
    root = preset_root()
    if not _HAS_REGISTRY and root is not None and (root / "presets" / sub).is_dir():
        dirs.append(str(root / "presets" / sub))
    return dirs


def _draw_legacy(self, _context):
    """``Menu.draw_preset`` over :func:`preset_dirs` (Blender < 4.2)."""
    self.path_menu(preset_dirs(self.preset_subdir), self.preset_operator,
                   filter_ext=lambda ext: ext.lower() == ".py",
                   display_name=lambda name: bpy.path.display_name(name, title_case=False))


def apply(kind: str, name: str) -> None:
    """Run the preset ``name`` of ``kind`` against the current scene."""
    files = preset_files(kind)
    path = files.get(name) or next((p for n, p in files.items() if p.stem == name), None)
    if path is None:
        from ..core import ReachError
        raise ReachError(f"no {kind} preset called '{name}'; known: {', '.join(sorted(files))}")
    exec(compile(path.read_text(), str(path), "exec"), {"bpy": bpy, "__file__": str(path)})


def _classes():
    out = []
    for kind, (group, names) in KINDS.items():
        target = "bpy.context.scene.reach" + (f".{group}" if group else "")
        menu = type(f"REACH_MT_{kind}_presets", (bpy.types.Menu,), {
            "bl_label": f"{kind.capitalize()} Presets",
            "preset_subdir": subdir(kind),
            "preset_operator": "script.execute_preset",
            "draw": bpy.types.Menu.draw_preset if _HAS_REGISTRY else _draw_legacy,
        })
        add = type(f"REACH_OT_{kind}_preset_add", (AddPresetBase, bpy.types.Operator), {
            "bl_idname": f"reach.{kind}_preset_add",
            "bl_label": f"Add {kind.capitalize()} Preset",
            "bl_description": f"Save or remove a Reach {kind} preset",
            "preset_menu": menu.__name__,
            "preset_defines": [f"reach = {target}"],
            "preset_values": [f"reach.{n}" for n in names],
            "preset_subdir": subdir(kind),
        })
        out += [menu, add]
    return tuple(out)


classes = _classes()


def register_paths():
    root = preset_root()
    if root is not None and _HAS_REGISTRY:
        bpy.utils.register_preset_path(str(root))


def unregister_paths():
    root = preset_root()
    if root is not None and _HAS_REGISTRY:
        bpy.utils.unregister_preset_path(str(root))


def apply_named(name: str) -> str:
    """Apply the preset called ``name`` of whichever kind has one; returns the kind."""
    for kind in KINDS:
        files = preset_files(kind)
        if name in files or any(p.stem == name for p in files.values()):
            apply(kind, name)
            return kind
    from ..core import ReachError

    known = sorted(n for k in KINDS for n in preset_files(k))
    raise ReachError(f"no preset called '{name}'; known: {', '.join(known)}")
