import bpy
reach = bpy.context.scene.reach.settings

# An example of restricted shoulders and trunk (stiffness, older age):
# about three quarters of the normal ranges; adjust to the person studied.

reach.alpha_min = -60.0
reach.alpha_max = 140.0
reach.beta_min = -45.0
reach.beta_max = 140.0
reach.gamma_min = -60.0
reach.gamma_max = 60.0
reach.elbow_min = 0.0
reach.elbow_max = 135.0
reach.wrist_bend_max = 70.0
reach.wrist_side_max = 25.0
reach.elevation_max = 140.0
reach.chest_rotation = True
reach.spine_share = 0.4
reach.trunk_turn_max = 25.0
reach.twist_weight = 1.0
reach.chest_rotation_max = 30.0
reach.table1_arm_length_m = 0.58
reach.table1_hand_point = 1.0
reach.chest_phase_delay = 0.25
reach.lean_max = 45.0
reach.lean = False
reach.lean_reach = 0.98
reach.lean_ready = 0.8
reach.lean_other_arm = 1.0
reach.lean_hips_back = True
reach.lean_hips_max = 0.3
reach.balance_margin = 0.02
reach.squat = True
reach.bend_max = 90.0
reach.spine_max = 80.0
reach.knee_max = 135.0
reach.ankle_max = 38.0
reach.hip_max = 120.0
reach.squat_step = 0.05
reach.stepping = True
reach.step_reach = 0.85
reach.step_length = 0.45
reach.steps_max = 6
reach.step_time = 0.5
reach.step_weight_time = 0.3
reach.step_weight_speed = 0.8
reach.step_weight = 1.0
reach.step_lift = 0.06
reach.gaze = False
reach.gaze_turn_max = 60.0
reach.gaze_down_max = 45.0
reach.gaze_up_max = 45.0
reach.gaze_time = 0.4
reach.gaze_speed = 250.0
