"""Test set-up shared by every suite.

``mathutils`` (and its ``bvhtree``) ship inside Blender; with the bpy wheel they become
importable once ``bpy`` is imported, so that happens first, here. The core itself never
imports bpy.
"""

import sys
from pathlib import Path

import bpy  # noqa: F401  (provides mathutils for the core under test)

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
