"""Helpers for the tests that run a real Blender binary (Debian's Blender 3.4.1): running
it with a timeout, reading what its scripts print, reading screenshots.

Without the system tools (``tools/system-deps.sh`` installs them) these tests skip, except
under CI, where they fail and say how to install them (the rule is ``system_tools``'s,
shared with every test that needs them).
"""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from system_tools import missing, require  # noqa: F401  (the binary tests' rule)

ROOT = Path(__file__).resolve().parents[2]
SCRIPTS = Path(__file__).resolve().parent / "scripts"
OUT = ROOT / "out" / "gui"
SCREEN = "1600x1000"
RIG = "quaternius"                    # tests/data/rigs/Quaternius_Female_Casual.fbx


def run(cmd, *, env=None, timeout, cwd=None) -> subprocess.CompletedProcess:
    """Run ``cmd`` in its own process group and return it finished. On timeout the whole
    group is killed (``xvfb-run`` starts Xvfb and Blender as children) and the test fails
    with the output so far."""
    cmd = [str(c) for c in cmd]
    with subprocess.Popen(cmd, env=env, cwd=cwd, stdin=subprocess.DEVNULL, stdout=subprocess.PIPE,
                          stderr=subprocess.PIPE, text=True, start_new_session=True) as proc:
        try:
            out, err = proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            out, err = proc.communicate()
            pytest.fail(f"{Path(cmd[0]).name} did not finish within {timeout} s:\n"
                        f"{out[-3000:]}\n{err[-3000:]}")
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def output(proc) -> str:
    return f"exit {proc.returncode}\n--- stdout\n{proc.stdout[-4000:]}\n--- stderr\n{proc.stderr[-4000:]}"


def tagged(proc, tag: str) -> dict:
    """The JSON a Blender script printed on a line starting with ``tag``."""
    for line in proc.stdout.splitlines():
        if line.startswith(tag + " "):
            return json.loads(line[len(tag) + 1:])
    raise AssertionError(f"no '{tag}' line in the output:\n{output(proc)}")


@dataclass
class Profile:
    """A private Blender 3.4 user profile with Reach installed and enabled."""

    blender: str
    root: Path
    env: dict

    @property
    def addon_dir(self) -> Path:
        return self.root / "scripts" / "addons" / "reach_addon"

    def blender_run(self, *args, timeout=120, cwd=None):
        return run([self.blender, *args], env=self.env, timeout=timeout, cwd=cwd)

    def blender_run_gui(self, *args, timeout=300):
        """Blender with its interface on a private X display (``xvfb_run``)."""
        return run([*xvfb_run(self.root, SCREEN), self.blender, *args], env=self.env,
                   timeout=timeout)


def xvfb_run(folder: Path, screen: str) -> list:
    """``xvfb-run`` on a free display, its X authority file in ``folder`` (ours to keep):
    left to itself, xvfb-run makes a temporary folder for it and exits 5, whatever Blender
    returned, when removing that folder fails at the end (it did once under CI, with the
    session recorded and Blender quit cleanly)."""
    auth = folder / f"xauthority-{os.getpid()}"
    auth.touch()
    return ["xvfb-run", "-a", "-f", str(auth), "-s", f"-screen 0 {screen}x24"]


ENABLE = """
import addon_utils, bpy, json, numpy
mod = addon_utils.enable("reach_addon", default_set=True, handle_error=None)
prefs = bpy.context.preferences
# llvmpipe (software OpenGL under Xvfb) redraws the viewport several times faster without
# multisampled overlays; the picture is the same but for smoothed edges.
prefs.system.viewport_aa = "OFF"
prefs.view.show_splash = False
prefs.use_preferences_save = False
bpy.ops.wm.save_userpref()
print("ENABLED " + json.dumps({"module": getattr(mod, "__file__", None), "numpy": numpy.__version__}))
"""



def make_profile(root: Path, blender: str) -> tuple:
    """A :class:`Profile` in the folder ``root`` (new, or empty): Reach (with its bundled presets, as
    ``make dist`` stages them) copied into its user scripts folder, enabled and kept
    enabled by saved preferences; with the Blender run that enabled it (``ENABLED`` line)."""
    (root / "config").mkdir(parents=True)
    (root / "tmp").mkdir()
    addon = root / "scripts" / "addons" / "reach_addon"
    ignore = shutil.ignore_patterns("__pycache__", "*.pyc")
    shutil.copytree(ROOT / "reach_addon", addon, ignore=ignore)
    shutil.copytree(ROOT / "presets", addon / "presets", ignore=ignore)
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("BLENDER_", "PYTHON", "VIRTUAL_ENV"))}
    env.update(BLENDER_USER_CONFIG=str(root / "config"), BLENDER_USER_SCRIPTS=str(root / "scripts"),
               TMPDIR=str(root / "tmp"))
    prof = Profile(blender, root, env)
    proc = prof.blender_run("--background", "--factory-startup", "--python-expr", ENABLE, timeout=60)
    return prof, proc


def build_scene(profile: Profile, small: bool = False) -> tuple:
    """The plate scene (``scripts/build_scene.py``) built from the rig :data:`RIG` (with
    ``small``, made 0.2 m tall, armature scale 0.0012) and saved in the profile's folder:
    the Blender run, and {"path", "armature", "target", "plate", "arm_length", "height",
    "scale"} (what it printed)."""
    path = profile.root / ("scene-small.blend" if small else "scene.blend")
    proc = profile.blender_run("--background", "--python", SCRIPTS / "build_scene.py", "--",
                               RIG, path, *(["small"] if small else []), timeout=120)
    return proc, {"path": path, **tagged(proc, "SCENE")}

# --- screenshots -------------------------------------------------------------------------------

def read_png(path) -> np.ndarray:
    """An image as (height, width, 3) uint8 RGB, top row first (read by ImageMagick)."""
    size = run(["identify", "-format", "%w %h", path], timeout=30)
    w, h = map(int, size.stdout.split())
    raw = subprocess.run(["convert", str(path), "-depth", "8", "rgb:-"], capture_output=True,
                         check=True, timeout=60).stdout
    return np.frombuffer(raw, np.uint8).reshape(h, w, 3)


def crop(img: np.ndarray, rect) -> np.ndarray:
    """The part of a window screenshot under a Blender region ``[x, y, width, height]``
    (window pixels, origin bottom left)."""
    x, y, w, h = rect
    top = img.shape[0] - (y + h)
    return img[top:top + h, x:x + w]


def strongly_red(img: np.ndarray) -> np.ndarray:
    """Pixels that are clearly red: bright in red, at most 40 % of it in green and blue.
    Shaded faces of Reach's trajectory material (0.9, 0.02, 0.02) are; Blender's grey
    interface, skin, and the orange selection outline are not."""
    i = img.astype(int)
    r, g, b = i[..., 0], i[..., 1], i[..., 2]
    return (r >= 110) & (g <= 0.4 * r) & (b <= 0.4 * r)


def text_rows(img: np.ndarray) -> int:
    """Rows of a sidebar crop (without its tab strip) holding light text or icons on the
    dark panel background: a measure of how much the panels show."""
    grey = img[:, :-30].astype(int).sum(-1) / 3
    return int(((grey > 150).sum(1) >= 2).sum())


def polyline_distance(points: np.ndarray, line: np.ndarray) -> np.ndarray:
    """Distance of each of ``points`` (n, 2) to the polyline through ``line`` (m, 2)."""
    best = np.full(len(points), np.inf)
    for a, b in zip(line[:-1], line[1:]):
        ab = b - a
        t = np.clip((points - a) @ ab / max(float(ab @ ab), 1e-12), 0.0, 1.0)
        best = np.minimum(best, np.linalg.norm(points - (a + t[:, None] * ab), axis=1))
    return best
