"""The text of a panel as Blender drew it: read from the buttons of the region's own blocks.

Blender 3.4's Python API cannot read what a region shows (``UILayout`` exists only while a
panel draws, and has no introspection; labels cannot be copied with Ctrl+C, and there is no
OCR here). What a region drew is kept in it until its next redraw, for the event handlers:
``ARegion.uiblocks``, a list of ``uiBlock`` (one per panel, named by the panel type's
idname), each with its list of ``uiBut`` — the labels among them, with the text given
(``str``) and the text drawn (``drawstr``: clipped with "…" where the region is too
narrow). This module walks that list with ``ctypes``, so a test sees the labels the panel
really put into the sidebar, not what a function computes when asked again.

Layouts relied on, each checked so that a wrong one stops the session with an error
instead of reading nonsense:

* ``ARegion`` is a DNA struct: the offset of its ``uiblocks`` is computed from the SDNA
  (the struct definitions every .blend carries) of a copy of the open file saved by this
  very Blender;
* ``uiBlock`` (``interface_intern.hh``, not DNA) begins with ``next``, ``prev`` and the
  ``buttons`` list; its ``name`` is found as the idname followed by a NUL in its first
  bytes;
* ``uiBut`` (``interface_intern.hh`` of Blender 3.4) begins with ``next``, and has ``str``
  (a pointer) at byte 64, then ``strdata[128]`` at 72, whose address ``str`` holds for
  every text shorter than 128 bytes (checked), then ``drawstr[400]`` at 200.
"""

import ctypes
import os
import struct
import tempfile

import bpy

TYPE, STR, STRDATA, DRAWSTR, RECT = 32, 64, 72, 200, 600
STRDATA_SIZE, DRAWSTR_SIZE = 128, 400
BLOCK_NAME_SEARCH = 512          # bytes of a uiBlock searched for its name (it is far larger)

_structs = {}


def sdna_offset(struct_name, field):
    """Byte offset of ``field`` in the DNA struct ``struct_name`` of this Blender, from the
    SDNA of a copy of the open file it saves uncompressed."""
    fields = sdna_struct(struct_name)
    if field not in fields:
        raise RuntimeError(f"SDNA: {struct_name} has no field {field}")
    return fields[field][0]


def sdna_struct(struct_name):
    """{field: (byte offset, size, type name)} of the DNA struct ``struct_name``."""
    if not _structs:
        _structs.update(_read_sdna())
    if struct_name not in _structs:
        raise RuntimeError(f"SDNA: no struct {struct_name}")
    return _structs[struct_name]


def _read_sdna():
    path = os.path.join(tempfile.mkdtemp(prefix="reach-sdna-"), "sdna.blend")
    bpy.ops.wm.save_as_mainfile(filepath=path, copy=True, compress=False)
    with open(path, "rb") as fh:
        data = fh.read()
    if data[:9] != b"BLENDER-v":
        raise RuntimeError(f"not a 64-bit little-endian .blend: {data[:12]!r}")
    pos = data.index(b"SDNANAME", data.index(b"DNA1")) + 8

    def u32():
        nonlocal pos
        pos += 4
        return struct.unpack_from("<I", data, pos - 4)[0]

    def strings(count):
        nonlocal pos
        out = []
        for _ in range(count):
            end = data.index(b"\0", pos)
            out.append(data[pos:end].decode())
            pos = end + 1
        return out

    def section(tag):
        nonlocal pos
        pos = (pos + 3) & ~3
        if data[pos:pos + 4] != tag:
            raise RuntimeError(f"SDNA: no {tag!r} section where expected")
        pos += 4

    names = strings(u32())
    section(b"TYPE")
    types = strings(u32())
    section(b"TLEN")
    lengths = struct.unpack_from(f"<{len(types)}H", data, pos)
    pos += 2 * len(types)
    section(b"STRC")
    structs = {}
    for _ in range(u32()):
        kind, count = struct.unpack_from("<HH", data, pos)
        fields = [struct.unpack_from("<HH", data, pos + 4 + 4 * k) for k in range(count)]
        pos += 4 + 4 * count
        offset, out = 0, {}
        for ftype, fname in fields:
            name = names[fname]
            size = 8 if name.startswith(("*", "(*")) else lengths[ftype]
            for dim in name.split("[")[1:]:
                size *= int(dim.rstrip("]"))
            out[name.lstrip("*(").split("[")[0].split(")")[0]] = (offset, size, types[ftype])
            offset += size
        structs[types[kind]] = out
    return structs


def _pointer(address):
    return ctypes.c_void_p.from_address(address).value or 0


def _text(address, size=None):
    """The NUL-terminated text at ``address`` (within ``size`` bytes if given)."""
    raw = ctypes.string_at(address) if size is None else ctypes.string_at(address, size)
    return raw.split(b"\0")[0].decode("utf-8", "replace")


def panel_text(region, idname):
    """[(text given, text drawn)] of the buttons of panel ``idname`` as ``region`` last drew
    it, in drawing order (top to bottom for a column of labels); None if the region drew no
    such panel."""
    buttons = panel_buttons(region, idname)
    return None if buttons is None else [(b["given"], b["drawn"]) for b in buttons]


def panel_buttons(region, idname):
    """The buttons of panel ``idname`` as ``region`` last drew it, in drawing order, each
    {"given": text given, "drawn": text drawn, "type": its ``eButType``, "rect": [xmin,
    xmax, ymin, ymax] in the block}; None if the region drew no such panel."""
    block = _pointer(region.as_pointer() + sdna_offset("ARegion", "uiblocks"))
    name = idname.encode() + b"\0"
    while block:
        if name in ctypes.string_at(block, BLOCK_NAME_SEARCH):
            return _buttons(block, idname)
        block = _pointer(block)
    return None


def _buttons(block, what):
    out = []
    but = _pointer(block + 16)
    while but:
        given = _pointer(but + STR)
        if not given:
            raise RuntimeError(f"{what}: a button without text at {but:#x}")
        text = _text(given)
        inline = given == but + STRDATA
        if inline != (len(text.encode()) < STRDATA_SIZE):
            raise RuntimeError(f"{what}: uiBut layout not as expected "
                               f"(str {given:#x}, button {but:#x}, {text[:40]!r})")
        out.append({"given": text, "drawn": _text(but + DRAWSTR, DRAWSTR_SIZE),
                    "type": ctypes.c_int.from_address(but + TYPE).value,
                    "rect": list(struct.unpack("<4f", ctypes.string_at(but + RECT, 16)))})
        but = _pointer(but)
    return out


def popups(screen):
    """The screen's temporary regions (popups, menus, tooltips: DNA ``bScreen.regionbase``),
    each {"rect": its ``winrct`` [xmin, xmax, ymin, ymax] in window pixels, "buttons": the
    buttons of all its blocks, as :func:`panel_buttons` gives them}."""
    region = _pointer(screen.as_pointer() + sdna_offset("bScreen", "regionbase"))
    blocks, winrct = sdna_offset("ARegion", "uiblocks"), sdna_offset("ARegion", "winrct")
    out = []
    while region:
        rect = list(struct.unpack("<4i", ctypes.string_at(region + winrct, 16)))
        buttons, block = [], _pointer(region + blocks)
        while block:
            buttons += _buttons(block, "popup")
            block = _pointer(block)
        out.append({"rect": rect, "buttons": buttons})
        region = _pointer(region)
    return out


def panels(region):
    """The region's panels (DNA ``Panel``, each followed by its sub-panels), each {"name":
    the panel type's idname, "flag", "ofsx", "ofsy" and "sizey" (its box below the header,
    in the region's view coordinates: its buttons' rectangles are offset from it by
    ``ofsx``, ``ofsy``), "depth", "address"}."""
    fields = sdna_struct("Panel")
    first = sdna_offset("ARegion", "panels")
    out = []

    def field(panel, name, fmt):
        return struct.unpack_from(fmt, ctypes.string_at(panel + fields[name][0], 4))[0]

    def walk(panel, depth):
        while panel:
            out.append({"name": _text(panel + fields["panelname"][0], 64),
                        "flag": field(panel, "flag", "<h"), "ofsx": field(panel, "ofsx", "<i"),
                        "ofsy": field(panel, "ofsy", "<i"),
                        "sizey": field(panel, "sizey", "<i"), "depth": depth, "address": panel})
            walk(_pointer(panel + fields["children"][0]), depth + 1)
            panel = _pointer(panel)

    walk(_pointer(region.as_pointer() + first), 0)
    return out


def set_panel_flag(address, flag):
    """Write a panel's DNA ``flag`` (e.g. to open a closed one)."""
    ctypes.c_short.from_address(address + sdna_offset("Panel", "flag")).value = flag


def view2d_cur(region):
    """The region's View2D ``cur`` rectangle [xmin, xmax, ymin, ymax] (view coordinates)."""
    at = region.as_pointer() + sdna_offset("ARegion", "v2d") + sdna_struct("View2D")["cur"][0]
    return list(struct.unpack("<4f", ctypes.string_at(at, 16)))
