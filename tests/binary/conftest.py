"""Reach in a real Blender binary: Debian's Blender 3.4.1, headless and in its interface
under Xvfb (helpers in ``binhost.py``).

Blender 3.4 has no extension system, so Reach is installed the way add-ons were before
4.2: the package (with its bundled presets, staged as ``make dist`` stages them) copied into
``<user scripts>/addons/reach_addon``, enabled with ``addon_utils.enable`` and kept enabled
by saving the preferences. The user folders are private temporary directories
(``BLENDER_USER_CONFIG``, ``BLENDER_USER_SCRIPTS``), so nothing touches the user's own
Blender. Every Blender run is a subprocess with a timeout.
"""

import json
import shutil
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent))

from binhost import (OUT, SCRIPTS, Profile, build_scene, make_profile, missing,  # noqa: E402
                     output, read_png, require, tagged)


@pytest.fixture(scope="session")
def profile(tmp_path_factory) -> Profile:
    """Reach copied into a fresh user scripts folder and enabled in saved preferences."""
    require("blender")
    prof, proc = make_profile(tmp_path_factory.mktemp("blender34"), shutil.which("blender"))
    if "No module named 'numpy'" in proc.stdout + proc.stderr:
        missing(["numpy"])
    info = tagged(proc, "ENABLED")
    assert info["module"] == str(prof.addon_dir / "__init__.py"), output(proc)
    assert (prof.root / "config" / "userpref.blend").is_file(), output(proc)
    return prof


@pytest.fixture(scope="session")
def scene(profile) -> dict:
    """The reach scene built by Blender 3.4 from a real rig (``scripts/build_scene.py``):
    {"path", "armature", "target", "plate", "arm_length"}."""
    proc, info = build_scene(profile)
    assert proc.returncode == 0 and info["path"].is_file(), output(proc)
    return info


@pytest.fixture(scope="session")
def small_scene(profile) -> dict:
    """The same scene with the character 0.2 m tall, small as a Mixamo import is (armature
    scale 0.0012): what the interface sessions and the README's picture use."""
    proc, info = build_scene(profile, small=True)
    assert proc.returncode == 0 and info["path"].is_file(), output(proc)
    assert abs(info["height"] - 0.2) < 1e-3 and abs(info["scale"] - 0.0012) < 1e-9, info
    return info


# The planner step for the session's Plan and Bake: twice the default, so they take half the
# time (each a second or two of planning, searched straight at the plate).
GUI_STEP = 0.04


@pytest.fixture(scope="session")
def gui_tools():
    """Everything the interface session needs, all named at once when some are missing."""
    require("blender", "xvfb-run", "xdotool", "convert")


@pytest.fixture(scope="session")
def gui(gui_tools, profile, small_scene) -> dict:
    """One interface session (``scripts/gui_session.py``) under Xvfb, on the small
    character: what it recorded, with the screenshots it took (copied to ``out/gui/`` for
    people to look at)."""
    scene = small_scene
    run_dir = profile.root / "gui"
    run_dir.mkdir(exist_ok=True)
    proc = profile.blender_run_gui(scene["path"], "--python", SCRIPTS / "gui_session.py", "--",
                                   run_dir, scene["armature"], scene["target"], GUI_STEP,
                                   timeout=300)
    (run_dir / "blender.log").write_text(output(proc))
    shutil.rmtree(OUT, ignore_errors=True)
    shutil.copytree(run_dir, OUT, dirs_exist_ok=True)
    assert (run_dir / "session.json").is_file(), output(proc)
    session = json.loads((run_dir / "session.json").read_text())
    assert "error" not in session, session["error"] + "\n" + output(proc)
    assert session.get("ok"), output(proc)
    # Blender 3.4 exits with status 1 after Esc was pressed in the session (Esc sets its
    # global "break" flag, which becomes the exit status); anything else is a crash.
    assert proc.returncode in (0, 1), output(proc)
    session["steps_by_name"] = {f"shot:{s['name']}" if s["step"] == "screenshot" else s["step"]: s
                                for s in session["steps"]}
    session["shots"] = {p.stem: read_png(p) for p in run_dir.glob("*.png")}
    return session
