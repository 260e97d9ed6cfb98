"""Test set-up shared by every suite.

``mathutils`` (and its ``bvhtree``) ship inside Blender; with the bpy wheel they become
importable once ``bpy`` is imported, so that happens first, here — after pointing Blender's
user folders at a private temporary directory, so tests never touch the user's Blender
settings and every run starts clean. The core itself never imports bpy.
"""

import os
import sys
import tempfile
from pathlib import Path

os.environ.setdefault("BLENDER_USER_RESOURCES", tempfile.mkdtemp(prefix="reach-tests-"))

import bpy  # noqa: E402,F401  (provides mathutils for the core under test)
import pytest  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))


_exit_status = {"code": 0}


def pytest_sessionfinish(session, exitstatus):
    _exit_status["code"] = int(exitstatus)


@pytest.hookimpl(trylast=True)
def pytest_unconfigure(config):
    """bpy 4.2 and 4.5 as a module crash while Python shuts down after the add-on's
    properties have been registered (:func:`reach_addon.compat.module_exit_crashes`): the
    run ends here, with pytest's own exit status, once everything is reported."""
    from reach_addon.compat import exit_module_blender, module_exit_crashes

    if module_exit_crashes():
        exit_module_blender(_exit_status["code"])
