"""The window of a scripted interface session (run inside Blender's interface): the main 3D
viewport and its regions, an override for operators, the X display's pointer and keys
(``xdotool``), and the sidebar's "Reach" tab found the way a user finds it."""

import subprocess

import bpy


def ui():
    """(window, the largest 3D viewport area, {region type: region})."""
    win = bpy.context.window_manager.windows[0]
    area = max((a for a in win.screen.areas if a.type == "VIEW_3D"), key=lambda a: a.width * a.height)
    return win, area, {r.type: r for r in area.regions}


def override():
    win, area, regions = ui()
    return bpy.context.temp_override(window=win, area=area, region=regions["WINDOW"])


def xdotool(*args):
    subprocess.run(["xdotool", *map(str, args)], check=True, timeout=20)


def to_screen(region, fx=0.5, fy=0.5):
    """X screen coordinates (origin top left) of a point of ``region``."""
    win, _area, _regions = ui()
    return (int(region.x + fx * region.width), int(win.height - (region.y + fy * region.height)))


def reach_tab(drawn, most=8):
    """Turn the sidebar's tabs with the mouse wheel over its tab strip (at its outer edge),
    one tab at a time, until ``drawn()`` (the count of the Reach main panel's draws, seen by
    a draw hook) is non-zero; a generator of the seconds to wait between turns, returning
    the number of turns."""
    x, y = to_screen(ui()[2]["UI"], 1.0, 0.5)
    x -= 12
    turns = 0
    while not drawn() and turns < most:
        xdotool("mousemove", x, y, "click", 5)
        turns += 1
        yield 0.6
    return turns


def button_xy(region, rect, cur, fx=0.5, fy=0.5):
    """X screen coordinates of a point of a button drawn in ``region``: ``rect`` [xmin, xmax,
    ymin, ymax] in the region's view (``drawn_text.panel_buttons``), ``cur`` the region's
    View2D ``cur`` rectangle (``drawn_text.view2d_cur``)."""
    x = rect[0] + fx * (rect[1] - rect[0])
    y = rect[2] + fy * (rect[3] - rect[2])
    px = (x - cur[0]) * region.width / (cur[1] - cur[0])
    py = (y - cur[2]) * region.height / (cur[3] - cur[2])
    win = ui()[0]
    return int(region.x + px), int(win.height - (region.y + py))
