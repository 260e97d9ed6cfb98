"""The fuzz campaign: seeded scenes, baked as a user bakes them, every outcome classified.

A seed becomes a scene description (:mod:`.scenes`, numpy only), the description a
``.blend`` file around a synthetic or real rig (:mod:`.building`), the file two bakes by
the command line in-process, and the bakes one outcome (:mod:`.checks`: the independent
check of a success, the refusal cross-check of a failure). :mod:`.campaign` runs seeds on
worker processes and :mod:`.summary` counts their outcomes for ``bench/fuzz.json`` and the
README. ``make fuzz`` runs it (``bench/fuzz.py``); ``tests/blender/test_fuzz.py`` runs a
fixed subset. The submodules are imported by name; this package imports none of them.
"""
