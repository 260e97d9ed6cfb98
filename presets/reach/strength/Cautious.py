import bpy
reach = bpy.context.scene.reach.settings

# Preferred levels at 45 degrees of elevation (RULA's upper-arm threshold):
# more poses count as weak, so the planner keeps the arm lower.

reach.preferred_level_h = 54.65
reach.preferred_level_v = 44.8689
reach.strength_reading = 'split'
reach.weight_alpha = 1.0
reach.weight_beta = 1.0
reach.weight_gamma = 1.5
reach.elbow_side = 'require'
