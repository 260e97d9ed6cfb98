"""``python -m reach_addon``: the command line, with the bpy wheel as the Blender host."""

import sys

from .cli import main

sys.exit(main())
