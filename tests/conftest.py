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

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
