"""Independent checks of what Reach claims, for the tests and the benchmarks.

Nothing here ships in the extension (``make dist`` packs ``reach_addon/`` alone) and nothing
under ``reach_addon/`` imports it; ``tests/`` and ``bench/`` both import it. The modules:

- :mod:`verification.geometry`: exact triangle geometry in numpy (distances, crossings,
  inside), sharing no code with the planner's collision checker;
- :mod:`verification.clearance`: the independent clearance oracle, an arm's capsules
  against obstacle triangles;
- :mod:`verification.refusal`: the refusal cross-check (is a failed reach's reason true?);
- :mod:`verification.race`: the harness racing Reach against OMPL on one problem;
- :mod:`verification.tight`: tight scenes sized to an arm's own limbs;
- :mod:`verification.table1`: Table 1 measured on baked motion;
- :mod:`verification.naturalness`: wrist bend and chicken-wing frames measured on baked
  motion;
- :mod:`verification.fuzz`: the fuzz campaign's scenes, their building in Blender, the
  checks of each outcome, the campaign's workers and its summary.

The rationale (why the oracle is written apart, the fuzz categories, the cross-check's
design) is in ``docs/design.md``.
"""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def rig_builders():
    """The tests' rig builders, ``tests/blender/rigs.py`` (the real test rigs of
    ``tests/data/rigs``) and ``tests/blender/synthetic.py`` (synthetic humanoids), as the
    modules ``(rigs, synthetic)``; their folder is put on ``sys.path`` first, where the tests
    import them from too. They need ``bpy``."""
    folder = str(ROOT / "tests" / "blender")
    if folder not in sys.path:
        sys.path.insert(0, folder)
    import rigs
    import synthetic

    return rigs, synthetic
