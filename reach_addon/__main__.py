"""``python -m reach_addon``: the command line, with the bpy wheel as the Blender host."""


if __name__ == "__main__":
    from .cli import main
    from .compat import exit_module_blender

    exit_module_blender(main())
