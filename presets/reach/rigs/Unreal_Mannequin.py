import bpy
reach = bpy.context.scene.reach

# Unreal Engine mannequin skeletons.

reach.use_overrides = True
reach.bone_chest = 'spine_03'
reach.bone_clavicle_right = 'clavicle_r'
reach.bone_upper_arm_right = 'upperarm_r'
reach.bone_forearm_right = 'lowerarm_r'
reach.bone_hand_right = 'hand_r'
reach.bone_clavicle_left = 'clavicle_l'
reach.bone_upper_arm_left = 'upperarm_l'
reach.bone_forearm_left = 'lowerarm_l'
reach.bone_hand_left = 'hand_l'
