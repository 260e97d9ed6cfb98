"""Blender-layer fixtures: the extension built by ``make dist``, installed into the
private user folder (see ``tests/conftest.py``) and enabled once per session; an empty
file per test."""

import os
import subprocess
import sys
from pathlib import Path

import bpy
import pytest

ROOT = Path(__file__).resolve().parents[2]
sys.path.insert(0, str(Path(__file__).resolve().parent))


def build_zip() -> Path:
    env = {k: v for k, v in os.environ.items() if not k.startswith("MAKE")}
    subprocess.run(["make", "-s", "dist"], cwd=ROOT, check=True, env=env, timeout=600,
                   stdout=subprocess.DEVNULL)
    version = next(line.split('"')[1] for line in (ROOT / "blender_manifest.toml").read_text().splitlines()
                   if line.startswith("version"))
    return ROOT / "dist" / f"reach_addon-{version}.zip"


@pytest.fixture(scope="session")
def addon_zip():
    return build_zip()


@pytest.fixture(scope="session")
def addon(addon_zip):
    """The installed, enabled extension's package (``bl_ext.user_default.reach_addon``)."""
    result = bpy.ops.extensions.package_install_files(
        filepath=str(addon_zip), repo="user_default", enable_on_install=True)
    assert result == {"FINISHED"}
    name = "bl_ext.user_default.reach_addon"
    assert name in bpy.context.preferences.addons.keys()
    yield sys.modules[name]
    # Disabled before Python exits, as Blender does on quit: bpy 4.2 and 4.5 as a module
    # crash at exit (segmentation fault) while a property group is still registered.
    if name in bpy.context.preferences.addons.keys():
        bpy.ops.preferences.addon_disable(module=name)


@pytest.fixture
def fresh(addon):
    """An empty file with the extension enabled."""
    bpy.ops.wm.read_homefile(use_empty=True)
    return bpy.context.scene
