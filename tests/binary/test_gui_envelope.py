"""The reach envelope's overlay in Blender 3.4.1's interface (under Xvfb): Compute runs
modal with progress, and the viewport then shows the envelope's points in their classes'
colours where the view projects them, and not once the overlay is hidden. The session is
``scripts/gui_envelope.py``; its screenshots are copied to ``out/gui/`` for people to
look at."""

import json
import shutil

import numpy as np
import pytest
from binhost import OUT, SCRIPTS, output, read_png


@pytest.fixture(scope="module")
def session(gui_tools, profile, scene):
    run_dir = profile.root / "gui_envelope"
    run_dir.mkdir(exist_ok=True)
    proc = profile.blender_run_gui(scene["path"], "--python", SCRIPTS / "gui_envelope.py", "--",
                                   run_dir, scene["armature"], timeout=300)
    (run_dir / "blender.log").write_text(output(proc))
    seen = json.loads((run_dir / "session.json").read_text()) \
        if (run_dir / "session.json").is_file() else {"error": output(proc)}
    assert "error" not in seen, seen["error"] + "\n" + output(proc)
    OUT.mkdir(parents=True, exist_ok=True)
    for name in ("envelope_on", "envelope_off"):
        shutil.copy(run_dir / f"{name}.png", OUT / f"{name}.png")
    seen["steps"] = {s["step"]: s for s in seen["steps"]}
    seen["shots"] = {n: read_png(run_dir / f"{n}.png") for n in ("envelope_on", "envelope_off")}
    return seen


def near_colour(img, rgb, tolerance=45):
    """Pixels within ``tolerance`` (per channel, 0–255) of colour ``rgb`` (0–1) as written
    straight to the screen (the overlay draws in display space) or through the sRGB
    transform (in case a version draws it colour-managed)."""
    rgb = np.asarray(rgb)[:3]
    srgb = np.where(rgb <= 0.0031308, 12.92 * rgb, 1.055 * rgb ** (1 / 2.4) - 0.055)
    img = img.astype(int)
    return ((np.abs(img - 255 * rgb) <= tolerance).all(-1)
            | (np.abs(img - 255 * srgb) <= tolerance).all(-1))


def test_compute_runs_modal_in_slices(session):
    step = session["steps"]["computed"]
    assert step["result"] == ["RUNNING_MODAL"]
    counts = step["counts"]
    assert sum(counts.values()) == 13 ** 3                 # the default grid
    assert counts["f_R 0"] > 20 and counts["out"] > 500
    assert step["progress"] and max(step["progress"]) < 1.0        # it ran in slices


def test_overlay_draws_each_class_where_its_points_project(session):
    from reach_addon.core.envelope import COLOURS

    on, off = session["shots"]["envelope_on"], session["shots"]["envelope_off"]
    where = session["steps"]["projected"]["where"]
    h, w = on.shape[:2]
    for code in ("0", "3"):                   # strong (green) and chest-only (blue) points
        pts = np.array(where[code])
        inside = (pts[:, 0] >= 2) & (pts[:, 0] < w - 2) & (pts[:, 1] >= 2) & (pts[:, 1] < h - 2)
        pts = np.round(pts[inside]).astype(int)
        assert len(pts) >= 10
        shown = near_colour(on, COLOURS[int(code)])
        hidden = near_colour(off, COLOURS[int(code)])
        # a dot of the class's colour within two pixels of where the point projects (the
        # depth test hides those behind the body)
        hit = [shown[y - 2:y + 3, x - 2:x + 3].any() for x, y in pts]
        assert np.mean(hit) > 0.5, f"class {code}: {np.mean(hit):.0%} of the dots seen"
        assert shown.sum() > 5 * max(1, hidden.sum()), "the colour comes from the overlay"
