"""The paper's four tasks on a sample workplace, with the statistics of Table 2.

:func:`core_demo` uses the core alone (the standard figure, furniture as triangle meshes)
and prints our Table 2 beside the paper's.
"""

from __future__ import annotations

import numpy as np

from .core import Planner, Settings, Task
from .samples import HANGING, obstacles, shelf, standard_arm, table

#: Table 2 of the paper: search time (s), nodes searched, nodes in solution, path length
#: (arm lengths).
PAPER_TABLE2 = {
    "collision_free": (2.906, 83, 54, 1.07),
    "rotation": (3.172, 157, 149, 2.99),
    "guided": (3.610, 170, 135, 2.69),
    "chase": (10.156, 426, 282, 5.68),
}

#: The workplace in front of the standard figure (world space, metres).
WORKPLACE = {
    "Table": table((-0.25, -0.62), (1.2, 0.5), 0.92),
    "Crate": [((-0.62, -0.37, 0.93), (0.02, -0.31, 1.10))],
    "Shelf": shelf((-0.62, -0.55), 0.5, 0.3, (1.05, 1.38), back_y_sign=-1),
}


def demo_tasks(fps: float = 24.0):
    """The four tasks of the paper's appendix: (name, Task)."""
    t = np.linspace(0.0, 1.0, 96)
    chase = np.stack([-0.12 + 0.18 * np.cos(2 * np.pi * t), -0.46 + 0.06 * np.sin(4 * np.pi * t),
                      1.28 + 0.12 * np.sin(2 * np.pi * t)], 1)
    return [
        ("collision_free", Task("reach", np.array([[-0.28, -0.47, 1.14]]), HANGING, fps,
                                names=("over the crate",))),
        ("rotation", Task("sequence", np.array([[-0.30, -0.45, 1.30], [-0.70, -0.15, 1.35],
                                                 [-0.62, 0.35, 1.35]]), HANGING, fps,
                          names=("front", "side", "behind"))),
        ("guided", Task("guided", np.array([[-0.45, -0.44, 1.22]]), HANGING, fps,
                        names=("in the shelf",))),
        ("chase", Task("chase", chase, HANGING, fps, names=("moving ball",))),
    ]


def core_demo(out) -> int:
    """Plan the four tasks with the core alone and print Table 2 beside the paper's."""
    arm = standard_arm()
    planner = Planner(arm, obstacles(WORKPLACE), Settings())
    rows = []
    for name, task in demo_tasks():
        p = planner.plan(task)
        rows.append((name, p))
        print(f"{name:15s} {'ok' if p.success else 'FAILED: ' + p.message}", file=out)
    print(file=out)
    print(f"{'task':15s} {'search s':>9s} {'paper s':>8s} {'nodes':>6s} {'paper':>6s} "
          f"{'in sol.':>7s} {'paper':>6s} {'length':>7s} {'paper':>6s}", file=out)
    for name, p in rows:
        t, n, k, length = PAPER_TABLE2[name]
        s = p.stats
        print(f"{name:15s} {s.search_time_s:9.3f} {t:8.3f} {s.nodes_searched:6d} {n:6d} "
              f"{s.nodes_in_solution:7d} {k:6d} {s.path_length_arm_lengths:7.2f} {length:6.2f}",
              file=out)
    if planner.has_workspace:
        print(f"\nworkspace preprocessing: {planner.workspace.build_time_s:.3f} s "
              f"(paper: about 6 s)", file=out)
    return 0 if all(p.success for _n, p in rows) else 1
