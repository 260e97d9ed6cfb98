import bpy
reach = bpy.context.scene.reach.settings

# Preferred levels at 90 degrees of elevation: only overhead work counts as weak.

reach.preferred_level_h = 44.3
reach.preferred_level_v = 28.4643
reach.strength_reading = 'split'
reach.weight_alpha = 1.0
reach.weight_beta = 1.0
reach.weight_gamma = 1.5
reach.elbow_side = 'require'
