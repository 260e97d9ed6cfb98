import bpy
reach = bpy.context.scene.reach.settings

# An Empty drawn as Plain Axes or Arrows (the default convention): the fingers point along
# +Y, the palm faces -Z (a hand lying on the Empty's XY plane, palm down). Match
# orientation on.

reach.match_orientation = True
reach.finger_axis = '+y'
reach.palm_axis = '-z'
reach.pronation_max = 80.0
reach.supination_max = 80.0
reach.orientation_tolerance = 10.0
reach.orientation_weight = 100.0
