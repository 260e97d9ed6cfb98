import bpy
reach = bpy.context.scene.reach

# Adobe Mixamo rigs (mixamorig: prefix).

reach.use_overrides = True
reach.bone_chest = 'mixamorig:Spine2'
reach.bone_clavicle_right = 'mixamorig:RightShoulder'
reach.bone_upper_arm_right = 'mixamorig:RightArm'
reach.bone_forearm_right = 'mixamorig:RightForeArm'
reach.bone_hand_right = 'mixamorig:RightHand'
reach.bone_clavicle_left = 'mixamorig:LeftShoulder'
reach.bone_upper_arm_left = 'mixamorig:LeftArm'
reach.bone_forearm_left = 'mixamorig:LeftForeArm'
reach.bone_hand_left = 'mixamorig:LeftHand'
