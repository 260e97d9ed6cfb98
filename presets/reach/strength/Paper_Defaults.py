import bpy
reach = bpy.context.scene.reach.settings

# Preferred levels: the strength left at 60 degrees of elevation (ISO 11226).

reach.preferred_level_h = 51.2
reach.preferred_level_v = 38.903079999999996
reach.strength_reading = 'split'
reach.weight_alpha = 1.0
reach.weight_beta = 1.0
reach.weight_gamma = 1.5
reach.elbow_side = 'require'
