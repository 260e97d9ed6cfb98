"""``python -m reach_addon``: the command line, with the bpy wheel as the Blender host."""

import sys

if __name__ == "__main__":
    from .cli import main

    sys.exit(main())
