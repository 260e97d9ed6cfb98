"""Digests of the plans a change must leave as they are: Table 2's four tasks and the demo.

Usage: ``python tools/plan_digest.py [--demo]`` (with the bpy wheel's Python). Prints one
line per task: its name, the number of poses and a SHA-256 of every pose's angles, joints,
wrist angles and roll (rounded to 1e-9), and with ``--demo`` one line for the demo's keys:
the SHA-256 of every keyframe (data path, index, frame, value rounded to 1e-6) of every
action in ``demo.blend``, made by ``python -m reach_addon demo --no-render`` in a
temporary folder. A refactoring that prints the same lines before and after changed no
plan, key for key.
"""

from __future__ import annotations

import argparse
import hashlib
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

import bpy  # noqa: E402,F401  (mathutils for the core)
import numpy as np  # noqa: E402


def _digest(arrays) -> str:
    h = hashlib.sha256()
    for a in arrays:
        h.update(np.round(np.asarray(a, dtype=float), 9).tobytes())
    return h.hexdigest()[:16]


def table2_lines() -> list:
    from geometry import obstacles, standard_arm
    from reach_addon.core import Planner, Settings
    from reach_addon.demo import WORKPLACE, demo_tasks

    out = []
    for name, task in demo_tasks():
        plan = Planner(standard_arm(), obstacles(WORKPLACE), Settings()).plan(task)
        rows = [np.concatenate([p.config.as_array(), p.joints.ravel(), p.hand, [p.roll]])
                for p in plan.poses]
        out.append(f"{name:15s} {len(plan.poses):4d} poses {_digest(rows)} "
                   f"nodes {plan.stats.nodes_searched}")
    return out


def demo_line() -> str:
    with tempfile.TemporaryDirectory() as folder:
        subprocess.run([sys.executable, "-m", "reach_addon", "demo", "--output", folder,
                        "--no-render"], cwd=ROOT, check=True, capture_output=True, timeout=1800)
        bpy.ops.wm.open_mainfile(filepath=str(Path(folder) / "demo.blend"))
        rows = []
        for action in sorted(bpy.data.actions, key=lambda a: a.name):
            curves = [fc for layer in getattr(action, "layers", ()) for strip in layer.strips
                      for bag in strip.channelbags for fc in bag.fcurves] \
                if hasattr(action, "layers") else list(action.fcurves)
            for fc in sorted(curves, key=lambda c: (c.data_path, c.array_index)):
                keys = np.array([k.co[:] for k in fc.keyframe_points]).ravel()
                rows.append(np.round(keys, 6))
                rows.append(np.frombuffer(f"{fc.data_path}{fc.array_index}".encode(), np.uint8))
        return f"demo keys       {sum(len(r) for r in rows[::2]) // 2:6d} keys {_digest(rows)}"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--demo", action="store_true", help="also digest the demo's keys")
    args = parser.parse_args(argv)
    for line in table2_lines():
        print(line)
    if args.demo:
        print(demo_line())
    return 0


if __name__ == "__main__":
    sys.exit(main())
