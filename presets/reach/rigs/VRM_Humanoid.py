import bpy
reach = bpy.context.scene.reach

# VRM / VRoid humanoid skeletons (J_Bip_ names).

reach.use_overrides = True
reach.bone_chest = 'J_Bip_C_UpperChest'
reach.bone_clavicle_right = 'J_Bip_R_Shoulder'
reach.bone_upper_arm_right = 'J_Bip_R_UpperArm'
reach.bone_forearm_right = 'J_Bip_R_LowerArm'
reach.bone_hand_right = 'J_Bip_R_Hand'
reach.bone_clavicle_left = 'J_Bip_L_Shoulder'
reach.bone_upper_arm_left = 'J_Bip_L_UpperArm'
reach.bone_forearm_left = 'J_Bip_L_LowerArm'
reach.bone_hand_left = 'J_Bip_L_Hand'
