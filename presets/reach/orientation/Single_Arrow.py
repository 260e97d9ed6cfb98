import bpy
reach = bpy.context.scene.reach.settings

# An Empty drawn as a Single Arrow: the fingers point along the arrow (+Z), the palm faces
# the Empty's -Y. Match orientation on.

reach.match_orientation = True
reach.finger_axis = '+z'
reach.palm_axis = '-y'
reach.pronation_max = 80.0
reach.supination_max = 80.0
reach.orientation_tolerance = 10.0
reach.orientation_weight = 100.0
