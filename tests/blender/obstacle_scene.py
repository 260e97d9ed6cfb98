"""Scenes holding one object of every type Blender has, and every kind of instancing, built
in code around a real rig (the bpy wheels 4.2–5.0 and the Blender 3.4.1 binary run the same
code). Everything is placed in the rig's own body frame and sized by its own arm length.

:func:`every_type` puts one of each round the character, out of the reaching arm's way;
:func:`blocker` puts one object of a kind (text, metaball, instanced cubes) across the
straight path from the wrist to a target in front of the shoulder, as ``rigs.plate_scene``
does with a box.
"""

from __future__ import annotations

import bpy
import numpy as np
from mathutils import Matrix

#: Objects with faces, by name, that Reach must use as obstacles in :func:`every_type`; the
#: labels it gives instances are "<instancer>" or "<instancer>/<instanced object>".
SURFACES = ("Mesh", "Curve bevel", "Surface", "Text", "Metaball", "GN realized", "GN cubes",
            "GN text", "Collection instance", "Particles")
#: Objects without faces: never obstacles.
NO_SURFACE = ("Curve wire", "Grease pencil", "Point cloud", "Volume", "Hair curves", "Empty",
              "Camera", "Light", "Light probe", "Speaker", "Lattice", "Props cube",
              "Particle ball")


def _frame_matrix(info, origin, normal=None):
    """A 4×4 world matrix at ``origin`` with local Z along ``normal`` (default the body's
    up) and local X across it."""
    f = info.frame
    z = f.up if normal is None else np.asarray(normal, float) / np.linalg.norm(normal)
    x = np.cross(f.up if abs(z @ f.up) < 0.9 else f.forward, z)
    x /= np.linalg.norm(x)
    m = np.eye(4)
    m[:3, 0], m[:3, 1], m[:3, 2], m[:3, 3] = x, np.cross(z, x), z, origin
    return m


def _place(ob, matrix, scale=1.0):
    m = np.array(matrix, float)
    m[:3, :3] *= scale
    ob.matrix_world = Matrix(m.tolist())


def _link(ob, collection=None):
    (collection or bpy.context.scene.collection).objects.link(ob)
    return ob


def add_text(name, matrix, size, body="H"):
    curve = bpy.data.curves.new(name, "FONT")
    curve.body = body
    curve.size = size
    curve.extrude = 0.15 * size
    curve.align_x = "CENTER"
    curve.align_y = "CENTER"
    ob = _link(bpy.data.objects.new(name, curve))
    _place(ob, matrix)
    return ob


def add_metaball(name, matrix, radius):
    mb = bpy.data.metaballs.new(name)
    mb.resolution = mb.render_resolution = radius / 8
    el = mb.elements.new()
    el.radius = radius
    ob = _link(bpy.data.objects.new(name, mb))
    _place(ob, matrix)
    return ob


def add_nurbs_sphere(name, matrix, radius):
    bpy.ops.surface.primitive_nurbs_surface_sphere_add(radius=radius)
    ob = bpy.context.object
    ob.name = name
    _place(ob, matrix)
    return ob


def add_curve(name, matrix, radius, bevel):
    bpy.ops.curve.primitive_bezier_circle_add(radius=radius)
    ob = bpy.context.object
    ob.name = name
    ob.data.bevel_depth = 0.2 * radius if bevel else 0.0
    _place(ob, matrix)
    return ob


def _tree(name, realize, instance):
    """A geometry-nodes group: Instance on Points on the input mesh's vertices, of a cube
    of ``instance`` (a size) or of an object (As Instance), realized or not."""
    tree = bpy.data.node_groups.new(name, "GeometryNodeTree")
    if hasattr(tree, "interface"):                             # 4.0+
        tree.interface.new_socket("Geometry", in_out="INPUT", socket_type="NodeSocketGeometry")
        tree.interface.new_socket("Geometry", in_out="OUTPUT", socket_type="NodeSocketGeometry")
    else:                                                      # 3.x
        tree.inputs.new("NodeSocketGeometry", "Geometry")
        tree.outputs.new("NodeSocketGeometry", "Geometry")
    nodes, links = tree.nodes, tree.links
    gin, gout = nodes.new("NodeGroupInput"), nodes.new("NodeGroupOutput")
    iop = nodes.new("GeometryNodeInstanceOnPoints")
    links.new(gin.outputs[0], iop.inputs["Points"])
    if isinstance(instance, bpy.types.Object):
        info = nodes.new("GeometryNodeObjectInfo")
        info.inputs["Object"].default_value = instance
        info.inputs["As Instance"].default_value = True
        links.new(info.outputs["Geometry"], iop.inputs["Instance"])
    else:
        cube = nodes.new("GeometryNodeMeshCube")
        cube.inputs["Size"].default_value = (instance,) * 3
        links.new(cube.outputs["Mesh"], iop.inputs["Instance"])
    out = iop.outputs["Instances"]
    if realize:
        real = nodes.new("GeometryNodeRealizeInstances")
        links.new(out, real.inputs["Geometry"])
        out = real.outputs["Geometry"]
    links.new(out, gout.inputs[0])
    return tree


def add_gn_instances(name, matrix, points, instance, realize=False):
    """A point-only mesh object (``points`` in its local space) whose geometry-nodes
    modifier instances a cube of size ``instance`` (or the object ``instance``) on every
    point."""
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata([tuple(map(float, p)) for p in points], [], [])
    ob = _link(bpy.data.objects.new(name, mesh))
    mod = ob.modifiers.new("Scatter", "NODES")
    mod.node_group = _tree(name, realize, instance)
    _place(ob, matrix)
    return ob


def grid_points(n, spacing):
    """An n × n grid of points in the local XY plane, centred on the origin."""
    c = (np.arange(n) - (n - 1) / 2) * spacing
    return np.array([(x, y, 0.0) for x in c for y in c])


def _cube_mesh(name, size):
    h = size / 2
    verts = [(x, y, z) for x in (-h, h) for y in (-h, h) for z in (-h, h)]
    faces = [(0, 1, 3, 2), (4, 6, 7, 5), (0, 4, 5, 1), (2, 3, 7, 6), (0, 2, 6, 4), (1, 5, 7, 3)]
    mesh = bpy.data.meshes.new(name)
    mesh.from_pydata(verts, [], faces)
    return mesh


def add_collection_instance(name, matrix, size):
    coll = bpy.data.collections.new("Props")
    coll.objects.link(bpy.data.objects.new("Props cube", _cube_mesh("Props cube", size)))
    ob = _link(bpy.data.objects.new(name, None))
    ob.instance_type = "COLLECTION"
    ob.instance_collection = coll
    _place(ob, matrix)
    return ob


def add_particles(name, matrix, size, count=12):
    """A plane emitting ``count`` particles drawn as instances of a small cube (the cube
    itself hidden), all born before frame 1 and not moving."""
    ball = _link(bpy.data.objects.new("Particle ball", _cube_mesh("Particle ball", 0.1 * size)))
    ball.hide_set(True)
    ob = _link(bpy.data.objects.new(name, _cube_mesh(name, size)))
    ob.scale = (1, 1, 0.02)
    mod = ob.modifiers.new("Particles", "PARTICLE_SYSTEM")
    ps = mod.particle_system.settings
    ps.count = count
    ps.frame_start, ps.frame_end, ps.lifetime = -10, -9, 10000
    ps.physics_type = "NO"
    ps.render_type = "OBJECT"
    ps.instance_object = ball
    ps.particle_size = 1.0
    m = np.array(matrix, float)
    m[:3, :3] = m[:3, :3] @ np.diag([1, 1, 0.02])
    ob.matrix_world = Matrix(m.tolist())
    return ob


def _add_grease_pencil(name):
    for op in ("gpencil_add", "grease_pencil_add"):             # 3.4–4.2 (GPENCIL), 4.3+
        try:
            getattr(bpy.ops.object, op)(type="STROKE")
        except (AttributeError, RuntimeError, TypeError):
            continue
        ob = bpy.context.object
        ob.name = name
        return ob
    raise RuntimeError("no grease pencil operator")


def _data_object(name, collection_name, *args):
    data = getattr(bpy.data, collection_name, None)
    if data is None:
        return None                   # this Blender has no such type (point clouds in 3.4)
    return _link(bpy.data.objects.new(name, data.new(name, *args)))


def add_without_surface(info, at):
    """One object of each type that has no faces, all at ``at`` (one world point); returns
    {name: Blender's type name}."""
    made = []
    made.append(_add_grease_pencil("Grease pencil"))
    made.append(_data_object("Point cloud", "pointclouds"))
    made.append(_data_object("Volume", "volumes"))
    made.append(_data_object("Hair curves", "hair_curves"))
    made.append(_link(bpy.data.objects.new("Empty", None)))
    made.append(_data_object("Camera", "cameras"))
    made.append(_data_object("Light", "lights", "POINT"))
    bpy.ops.object.lightprobe_add()
    probe = bpy.context.object
    probe.name = "Light probe"
    made.append(probe)
    made.append(_data_object("Speaker", "speakers"))
    made.append(_data_object("Lattice", "lattices"))
    out = {}
    for ob in made:
        if ob is not None:
            ob.location = tuple(map(float, at))
            out[ob.name] = ob.type
    return out


def every_type(info):
    """One of each object type and instancing kind round the character, at about 1.3–1.6
    arm lengths from the spine behind and beside it, where the reaching arm does not go.
    Returns {name: type} of what was made (Blender's type names)."""
    f, length = info.frame, info.arm.arm_length
    o = f.origin
    s = 0.12 * length                                   # a typical object's size

    def at(back, side, up=0.0):
        return o - f.forward * back * length + f.right * side * length + f.up * up * length

    ring = {}
    bpy.ops.mesh.primitive_cube_add(size=s)
    ring["Mesh"] = bpy.context.object
    ring["Mesh"].name = "Mesh"
    _place(ring["Mesh"], _frame_matrix(info, at(1.4, -0.8)))
    ring["Curve bevel"] = add_curve("Curve bevel", _frame_matrix(info, at(1.4, -0.4)), s, True)
    ring["Curve wire"] = add_curve("Curve wire", _frame_matrix(info, at(1.4, -0.4, 0.4)), s, False)
    ring["Surface"] = add_nurbs_sphere("Surface", _frame_matrix(info, at(1.4, 0.0)), s / 2)
    ring["Text"] = add_text("Text", _frame_matrix(info, at(1.4, 0.4), -f.forward), s)
    ring["Metaball"] = add_metaball("Metaball", _frame_matrix(info, at(1.4, 0.8)), s / 2)
    ring["GN realized"] = add_gn_instances("GN realized", _frame_matrix(info, at(1.6, -0.8)),
                                           grid_points(3, 0.5 * s), 0.3 * s, realize=True)
    ring["GN cubes"] = add_gn_instances("GN cubes", _frame_matrix(info, at(1.6, -0.4)),
                                        grid_points(3, 0.5 * s), 0.3 * s)
    glyph = add_text("Glyph", _frame_matrix(info, at(3.0, 0.0)), 0.5 * s, "A")
    glyph.hide_set(True)              # seen only through the instances
    ring["GN text"] = add_gn_instances("GN text", _frame_matrix(info, at(1.6, 0.0)),
                                       grid_points(2, 0.6 * s), glyph)
    ring["Collection instance"] = add_collection_instance(
        "Collection instance", _frame_matrix(info, at(1.6, 0.4)), s)
    ring["Particles"] = add_particles("Particles", _frame_matrix(info, at(1.6, 0.8)), s)
    made = {name: ob.type for name, ob in ring.items()}
    made.update(add_without_surface(info, at(1.4, 0.0, 0.6)))
    bpy.context.view_layer.update()
    return made


def blocker(kind, info, target, start):
    """An object of ``kind`` ('text', 'metaball', 'cubes') across the straight path from
    ``start`` to ``target``, half way, facing along it, about a third of the path wide."""
    path = np.asarray(target, float) - np.asarray(start, float)
    span = float(np.linalg.norm(path))
    m = _frame_matrix(info, np.asarray(start) + 0.5 * path, path)
    if kind == "text":
        ob = add_text("Blocker", m, 0.3 * span, "H")
    elif kind == "metaball":
        ob = add_metaball("Blocker", m, 0.2 * span)
    elif kind == "cubes":
        n, spacing = 5, 0.08 * span
        ob = add_gn_instances("Blocker", m, grid_points(n, spacing), 1.05 * spacing)
    else:
        raise ValueError(kind)
    bpy.context.view_layer.update()
    return ob


def evaluated_triangles(ob):
    """World-space triangles (T, 3, 3) of what Blender shows for ``ob``, read independently
    of Reach: every mesh instance of the depsgraph whose instancer (or itself) is ``ob``,
    copied inside the iteration. (Curves, surfaces, text and metaballs come through as a
    mesh instance of themselves on Blender 3.4–5.0.)"""
    dg = bpy.context.evaluated_depsgraph_get()
    out = []
    for inst in dg.object_instances:
        owner = inst.parent if inst.is_instance and inst.parent is not None else inst.object
        if owner.original.name != ob.name or inst.object.type != "MESH":
            continue
        mesh = inst.object.data
        mesh.calc_loop_triangles()
        co = np.array([v.co[:] for v in mesh.vertices]).reshape(-1, 3)
        tri = np.array([t.vertices[:] for t in mesh.loop_triangles], int).reshape(-1, 3)
        mw = np.array(inst.matrix_world)
        out.append((co @ mw[:3, :3].T + mw[:3, 3])[tri])
    return np.concatenate(out) if out else np.zeros((0, 3, 3))


def check_gathered(found):
    """What one host printed (``tests/binary/scripts/obstacle_types.py``): every gather gives
    the same obstacles, exactly the objects with faces, each with the triangles Blender
    shows for it (read independently), and the live cache walks the same objects."""
    made, runs = found["made"], found["runs"]
    assert all(run == runs[0] for run in runs), "gathers of one scene differ"
    counts = {}
    for label, n in runs[0]:
        assert n > 0, label
        owner = label.split("/")[0]
        counts[owner] = counts.get(owner, 0) + n
    assert set(counts) == set(SURFACES), counts
    for name, n in counts.items():
        assert n == found["independent"][name], (name, n, found["independent"][name])
    for name in NO_SURFACE:
        if name in made:
            assert found["independent"][name] == 0, name
            assert name not in counts
    assert {"GREASEPENCIL", "GPENCIL"} & set(made.values())
    assert {"POINTCLOUD", "VOLUME", "CURVES", "LATTICE", "SPEAKER", "LIGHT_PROBE"} <= set(made.values())
    assert {owner for owner, _name in found["signature"]} >= set(SURFACES)
