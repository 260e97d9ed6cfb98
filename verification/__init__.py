"""Independent checks of what Reach claims, for the tests and the benchmarks.

Nothing here ships in the extension (``make dist`` packs ``reach_addon/`` alone) and
nothing under ``reach_addon/`` imports it. :mod:`verification.refusal` cross-checks a
failed reach's reason (is the refusal true?); :mod:`verification.geometry` is exact
triangle geometry in numpy, sharing no code with the planner's collision checker, and
:mod:`verification.clearance` the independent clearance oracle built on it (an arm's
capsules against obstacle triangles), which the tests and the benchmarks measure with.
"""
