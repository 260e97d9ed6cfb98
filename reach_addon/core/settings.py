"""Settings: the one object behind the UI properties, the presets and the CLI flags.

Every tunable of the planner is a field here, with its default, its unit, its range and a
sentence on where the default comes from. The Blender property group, the preset files and
the command-line flags are all generated from :func:`fields` so there is one source of
defaults.

Units: angles in degrees; lengths in **arm lengths** (upper arm + forearm of the rig in
hand, so a figure 4.7 units tall plans exactly like one 1.75 m tall); times in seconds.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

from .errors import ReachError
from .orient import AXES
from .strength import PREFERRED_LEVEL_H, PREFERRED_LEVEL_V, READINGS, S_H_MIN, S_V_MIN
from .torso import CHEST_ROTATION_MAX_DEG, TABLE1_HAND_POINT, TABLE1_REFERENCE_ARM_LENGTH_M


def _f(default, label, doc, group, lo=None, hi=None, unit="", choices=None):
    meta = {"label": label, "doc": doc, "group": group, "min": lo, "max": hi, "unit": unit}
    if choices:
        meta["choices"] = choices
    return field(default=default, metadata=meta)


#: The planner's groups of settings (each a sub-panel of Planner Settings); the reach
#: envelope's fields (group "envelope") are drawn by the Envelope panel.
GROUPS = ("strength", "limits", "body", "step", "ik", "collision", "search", "workspace", "motion",
          "orientation")


@dataclass(frozen=True)
class Settings:
    """All planner settings; frozen, so a plan can keep the exact settings it used."""

    # --- strength model (paper, "Human strength model") ------------------------------------
    preferred_level_h: float = _f(
        PREFERRED_LEVEL_H, "Level SL_H",
        "Horizontal strength a comfortable posture keeps; default S_H(60°), the ISO 11226 "
        "limit of acceptable upper-arm elevation", "strength", round(S_H_MIN + 0.1, 3), 65.0)
    preferred_level_v: float = _f(
        PREFERRED_LEVEL_V, "Level SL_V",
        "Vertical strength a comfortable posture keeps; default S_V(60°) by the same "
        "argument", "strength", round(S_V_MIN + 0.1, 3), 65.75)
    weight_alpha: float = _f(
        1.0, "Weight ω_α", "Exertion weight of abduction/adduction (1 / relative peak "
        "strength: S_H peaks at 65, the reference)", "strength", 0.0, 10.0)
    weight_beta: float = _f(
        1.0, "Weight ω_β", "Exertion weight of flexion/extension (S_V peaks at 65.75, "
        "within 1% of S_H's peak)", "strength", 0.0, 10.0)
    weight_gamma: float = _f(
        1.5, "Weight ω_γ", "Exertion weight of humeral twist. The paper has no rotation "
        "curve; the rotator cuff is taken as about two thirds as strong as the abductors",
        "strength", 0.0, 10.0)
    strength_reading: str = _f(
        "split", "Angle reading", "Which shoulder angles S_H and S_V are read at: 'split', "
        "the elevation split by the direction it is raised toward (α = θ cos φ, β = θ sin φ; "
        "continuous as the arm hangs, the default), or 'horizontal', the arm's direction in "
        "the horizontal plane and its elevation (as reference 11 pulled 'in the horizontal "
        "plane')", "strength", choices=READINGS)
    elbow_side: str = _f(
        "require", "Elbow side", "Algorithm 1: 'require' keeps only elbows on the preferred "
        "side, 'prefer' tries them first, 'off' ignores the rule", "strength",
        choices=("require", "prefer", "off"))

    # --- joint limits (AAOS normal ranges of motion; see core.arm) -------------------------
    alpha_min: float = _f(-60.0, "Adduction", "Least α (the S_H curve's domain)",
                          "limits", -90.0, 0.0, "deg")
    alpha_max: float = _f(180.0, "Abduction", "Greatest α (AAOS: 180°)",
                          "limits", 90.0, 180.0, "deg")
    beta_min: float = _f(-60.0, "Extension", "Least β (AAOS: 60° extension)",
                         "limits", -90.0, 0.0, "deg")
    beta_max: float = _f(180.0, "Flexion", "Greatest β (AAOS: 180°)",
                         "limits", 90.0, 180.0, "deg")
    gamma_min: float = _f(-90.0, "External rotation", "Least γ (AAOS: 90° external)",
                          "limits", -180.0, 0.0, "deg")
    gamma_max: float = _f(90.0, "Internal rotation", "Greatest γ (AAOS gives 70° at "
                          "90° abduction; at the side the trunk, not the joint, stops it)",
                          "limits", 0.0, 180.0, "deg")
    elbow_min: float = _f(0.0, "Elbow extension", "Least elbow flexion", "limits",
                          0.0, 90.0, "deg")
    elbow_max: float = _f(150.0, "Elbow flexion", "Greatest elbow flexion (AAOS: 150°)",
                          "limits", 90.0, 170.0, "deg")
    wrist_bend_max: float = _f(
        70.0, "Wrist bend", "Greatest bend of the hand in the elbow's plane (AAOS "
        "wrist extension 70°, flexion 80°)", "limits", 0.0, 90.0, "deg")
    wrist_side_max: float = _f(
        25.0, "Wrist side", "Greatest bend of the hand across the elbow's plane "
        "(AAOS radial 20°, ulnar 30°)", "limits", 0.0, 45.0, "deg")
    elevation_max: float = _f(
        170.0, "Elevation", "Greatest angle between the upper arm and the hanging "
        "direction; the shoulder-angle decomposition is singular straight overhead",
        "limits", 90.0, 179.0, "deg")

    # --- body rotation (paper, Table 1) -----------------------------------------------------
    chest_rotation: bool = _f(True, "Body rotation", "Read chest rotation from the reach "
                              "direction by Table 1", "body")
    chest_rotation_max: float = _f(
        CHEST_ROTATION_MAX_DEG, "Max chest turn", "Greatest chest rotation against the "
        "feet (Table 1 measures it so; the pelvis and spine share it: Trunk turn, Spine "
        "share). Standing people reach "
        "about 96° (Montgomery et al. 2011: trunk 32.6° + pelvis 63.8°); 60° is above every "
        "Table 1 value up to 170° of direction", "body", 0.0, 90.0, "deg")
    spine_share: float = _f(
        0.4, "Spine share", "Share of the chest's turn that the spine bones below the chest "
        "take, each by its length, the chest keeping its pose: people spread a trunk's turn "
        "over the thoracolumbar spine, and in White & Panjabi's representative segment "
        "values (1990) the segments below the mid-thorax give a little under half of it. "
        "0: the chest bone turns alone (and the pelvis stays)", "body", 0.0, 0.9)
    trunk_turn_max: float = _f(
        33.0, "Trunk turn", "Greatest turn of the chest against the pelvis: where Table 1's "
        "turn goes past it, the pelvis turns over the planted feet and takes the rest, the "
        "legs following (standing people turning to reach: trunk 32.6°, pelvis 63.8°, "
        "Montgomery et al. 2011). At Max chest turn or above, the pelvis never turns",
        "body", 0.0, 90.0, "deg")
    table1_arm_length_m: float = _f(
        TABLE1_REFERENCE_ARM_LENGTH_M, "Table 1 arm",
        "Shoulder-to-wrist length of the adult Table 1 is read for (a 1.75 m adult by "
        "Drillis & Contini); a figure's reach distance is scaled by this over its own arm "
        "length", "body", 0.3, 1.0, "m")
    table1_hand_point: float = _f(
        TABLE1_HAND_POINT, "Hand point",
        "Where Table 1's reach distance is measured, as a share of the hand's length beyond "
        "the wrist: 1 the fingertips (default), 0.4 the centre of a grip, 0 the wrist",
        "body", 0.0, 1.0)
    lean_max: float = _f(
        45.0, "Lean limit", "Farthest trunk lean (at the hips) that a target beyond the "
        "arm's reach is leaned for (with Lean on) or reported as 'reachable by leaning'; "
        "farther, by stepping. Well within the AAOS ranges (1965) of the spine's flexion, "
        "80°, and the hip's, 120°, which a lean shares", "body", 0.0, 90.0, "deg")
    lean: bool = _f(
        True, "Lean", "Lean the trunk at the hips, feet planted, where a single reach's "
        "target is beyond the arm: the trunk leans first, then the arm reaches (with Hips "
        "back, Squat and Step below). Off: the arm and chest alone, as the paper plans "
        "them, and a target beyond them refused with the reason", "body")
    lean_reach: float = _f(
        0.98, "Lean to", "A lean brings the target this far from the shoulder (arm "
        "lengths): people reaching by a lean extend the arm nearly straight (the functional "
        "reach test); 0.98 leaves the elbow bent about 23° on equal arm segments", "body",
        0.5, 1.0)
    twist_weight: float = _f(
        1.0, "Twist effort", "Weight of the chest's turn past Table 1's against a lean in "
        "the trunk's effort (normalized joint displacement, Yang, Marler et al. 2004): "
        "where the chest was turned past Table 1's to bring a target beyond the arm "
        "within reach, the trunk leans instead wherever that costs less. 0: a twist costs "
        "nothing, and the trunk leans only where no turn of the chest reaches", "body",
        0.0, 10.0)
    lean_ready: float = _f(
        0.8, "Ready reach", "Where the arm, held as it stands, would touch or find no way "
        "as the trunk leans, it first reaches on the upright trunk this far (a share of "
        "the way from the shoulder) toward where the target will be once leaned, then the "
        "trunk leans, then the arm reaches the rest: people raise the arm before they "
        "lean. 0: never (such a lean is refused)", "body", 0.0, 1.0)
    lean_other_arm: float = _f(
        1.0, "Other arm steady", "How far the arm that does not reach keeps the direction "
        "it had in the world as the trunk leans, instead of riding on the trunk, which in a "
        "deep bend with the chest turned swings it up behind the back (1: all the way; 0: "
        "it rides). Halved, then left out, where it would touch or tip the body", "body",
        0.0, 1.0)
    lean_hips_back: bool = _f(
        True, "Hips back", "Where a lean would carry the centre of mass past the feet (or "
        "within Balance margin of their edge), move the hips back, the feet planted and the "
        "knees bending, and lean as much more as that needs (the hip strategy of a forward "
        "reach)", "body")
    lean_hips_max: float = _f(
        0.3, "Hips back limit", "Farthest the hips move back for a lean (arm lengths)",
        "body", 0.0, 1.0)
    balance_margin: float = _f(
        0.02, "Balance margin", "How far inside the feet's support polygon the hips' shift "
        "keeps the centre of mass (arm lengths; the rig's own margin as it stands where "
        "that is less than 0)", "body", 0.0, 0.2)
    squat: bool = _f(
        True, "Squat", "With Lean on, where no standing lean reaches a low target, squat or "
        "bend: the hips come down and back, the knees and ankles bend, the trunk leans "
        "farther, the feet planted (the least effort within the limits below)", "body")
    bend_max: float = _f(
        90.0, "Bend limit", "Farthest trunk lean in a squat or bend, from upright. A person "
        "shares it between the pelvis's tilt at the hips and the spine's flexion; Reach "
        "leans the trunk at the spine's lowest joint, and holds the lean plus the thigh's "
        "flexion within Hip limit + Spine limit", "body", 0.0, 90.0, "deg")
    spine_max: float = _f(
        80.0, "Spine limit", "The spine's flexion that a squat's lean may take beyond what "
        "the hips give (see Bend limit): the AAOS average thoracolumbar flexion (1965)",
        "body", 0.0, 120.0, "deg")
    knee_max: float = _f(
        135.0, "Knee limit", "Greatest knee flexion in a squat: the AAOS average (1965)",
        "body", 0.0, 160.0, "deg")
    ankle_max: float = _f(
        38.0, "Ankle limit", "Greatest ankle dorsiflexion in a squat, the shin tipping over "
        "the planted foot from where it stands: the upper end of what clinicians take as "
        "normal in the weight-bearing lunge test (30-38°); the AAOS average, 20°, is "
        "measured off the ground", "body", 0.0, 60.0, "deg")
    hip_max: float = _f(
        120.0, "Hip limit", "Greatest hip flexion in a squat, the thigh's angle from the "
        "pelvis's down: the AAOS average (1965)", "body", 0.0, 150.0, "deg")
    squat_step: float = _f(
        0.05, "Squat grid", "Spacing of the grid of hips' drops and shifts a squat is "
        "chosen from (arm lengths)", "body", 0.005, 0.2)
    stepping: bool = _f(
        True, "Step", "With Lean on, where no lean or squat brings a single reach's target "
        "within reach, step toward it first: the weight shifts, the foot on its side "
        "swings and is placed, the other follows, as many steps as Steps limit allows, "
        "then the arm reaches (leaning or squatting for the rest)", "step")
    step_reach: float = _f(
        0.85, "Step to", "A step brings the target this far from the shoulder (arm "
        "lengths): near enough that the arm reaches it without stretching straight", "step",
        0.3, 1.0)
    step_length: float = _f(
        0.45, "Step length", "Longest step, in leg lengths (hip to ankle). A step to the "
        "side lands while the weight is over the other foot: a leg reaching 0.45 of its "
        "length to the side of its hip comes down by 11 % of it (the hips bend the knees "
        "that much); a walking step, about 0.8, has the body between the feet", "step",
        0.1, 1.2)
    steps_max: int = _f(
        6, "Steps limit", "Most steps a reach takes toward its target; farther is refused "
        "as needing to walk", "step", 1, 8)
    step_time: float = _f(
        0.5, "Swing time", "Seconds a foot takes to swing to its new place (a minimum-jerk "
        "swing: the swing phase of gait is about 0.4 s)", "step", 0.1, 2.0, "s")
    step_weight_time: float = _f(
        0.3, "Shift time", "Seconds the weight takes to shift onto the foot that "
        "stays, before the other lifts, and back between the feet after the last step",
        "step", 0.1, 2.0, "s")
    step_weight_speed: float = _f(
        0.8, "Shift speed", "Fastest the hips move on average as the weight shifts, "
        "leg lengths a second (about 0.7 m/s on an adult): a shift across a wide stance "
        "takes longer than Shift time", "step", 0.1, 3.0)
    step_weight: float = _f(
        1.0, "Weight shift", "How far the hips move over the foot that stays while the "
        "other swings (a share of the way from over the feet's middle to over its ankle)",
        "step", 0.0, 1.5)
    step_lift: float = _f(
        0.06, "Foot lift", "How high a swinging foot rises at mid-swing (leg lengths; "
        "about 5 cm on an adult)", "step", 0.0, 0.3)
    gaze: bool = _f(
        False, "Look at target", "Turn the head toward each target (at the neck, within its "
        "limits), ahead of the hand, and keep it there as the body moves. Off by default: "
        "it keys the head on every bake", "body")
    gaze_turn_max: float = _f(
        60.0, "Neck turn", "Farthest the neck turns the head left or right: the "
        "AAOS average cervical rotation (1965)", "body", 0.0, 90.0, "deg")
    gaze_down_max: float = _f(
        45.0, "Neck flexion", "Farthest the neck tips the head down: the AAOS average "
        "cervical flexion (1965)", "body", 0.0, 90.0, "deg")
    gaze_up_max: float = _f(
        45.0, "Neck extension", "Farthest the neck tips the head up: the AAOS average "
        "cervical extension (1965)", "body", 0.0, 90.0, "deg")
    gaze_time: float = _f(
        0.4, "Head turn time", "Seconds the head takes to turn toward a new target (a "
        "minimum-jerk turn; head movements of a 40-60° gaze shift take 0.3-0.5 s)", "body",
        0.05, 2.0, "s")
    gaze_speed: float = _f(
        250.0, "Head turn speed", "Fastest the head turns, degrees a second, on each of its "
        "two angles (within the peak head velocities of large gaze shifts)", "body",
        30.0, 720.0, "deg/s")
    chest_phase_delay: float = _f(
        0.25, "Chest delay", "Fraction of a reach's progress toward its target before "
        "the chest starts to turn (joints are recruited in turn, arm first)", "body", 0.0, 0.9)

    # --- analytic IK -------------------------------------------------------------------------
    swivel_step: float = _f(5.0, "Swivel step", "Sampling step of the elbow swivel circle",
                            "ik", 0.5, 45.0, "deg")
    max_joint_step: float = _f(
        15.0, "Smoothness", "Greatest change of any joint angle between consecutive "
        "wrist positions one search step apart (scaled up for longer moves)", "ik",
        1.0, 90.0, "deg")
    elbow_comfort: float = _f(
        10.0, "Elbow comfort", "Where a path lifts the elbow over a low hand (a chicken "
        "wing), its swivels are chosen again along the whole path, each arm length the "
        "elbow rises above the shoulder while the hand is below it costing this many levels "
        "of the strength category f_R (10: a lift of 0.1 arm lengths costs one level). "
        "0 keeps the search's strongest-first choice everywhere", "ik", 0.0, 100.0)
    wing_margin: float = _f(
        0.1, "Wing margin", "A pose is a chicken wing when its elbow is more than "
        "this many arm lengths above the shoulder while the wrist is more than this below "
        "it", "ik", 0.0, 0.5, "arm lengths")

    # --- the hand over the finished motion (core.hand) --------------------------------------
    hand_turn_speed: float = _f(
        360.0, "Hand turn speed", "Fastest turn of the hand relative to the forearm: "
        "360°/s is 15° a frame at 24 fps. Peak wrist angular speeds in brisk everyday "
        "reaching and placing stay below about 300-400°/s, and animators read a turn of "
        "20-30° in one frame as a pop", "motion", 30.0, 2000.0, "deg/s")
    hand_space_turn_speed: float = _f(
        360.0, "Hand space turn", "Fastest turn of the hand's orientation in space, "
        "the forearm's own turn and roll included (the hand turns against the forearm to keep "
        "to it, else the motion slows): the same 360°/s, 15° a frame at 24 fps, so no bone of "
        "the hand, finger or thumb, pops either", "motion", 30.0, 2000.0, "deg/s")
    limb_turn_speed: float = _f(
        360.0, "Limb turn speed", "Fastest turn of the upper arm or the forearm in space: an "
        "automatic duration is stretched (up to twice) where the minimum-jerk peak would turn "
        "a limb faster (15° a frame at 24 fps, as for the hand)", "motion", 30.0, 2000.0,
        "deg/s")
    wrist_relax_weight: float = _f(
        2.0, "Wrist relax", "How strongly the hand is drawn back toward neutral (in "
        "line with the forearm) against how smoothly it turns: a frame bent 45° costs this "
        "much, a turn at the speed limit costs 1. At 2 a hand bent 10° left alone for ten "
        "frames costs more than turning back at a third of the limit, so it relaxes", "motion",
        0.0, 100.0)
    hand_grid_step: float = _f(
        5.0, "Hand angle step", "Spacing of the wrist-bend angles the hand pass chooses "
        "from (side bends are spaced 2.5 times wider, their range being a third as large)",
        "motion", 1.0, 15.0, "deg")
    instants_per_frame: int = _f(
        4, "Checks per frame", "Instants per frame at which the arm and the hand are "
        "checked against obstacles as the keys interpolate (frame, then evenly between)",
        "motion", 1, 16)
    slowdown_budget: float = _f(
        1.0, "Max slow-down", "Most frames the hand pass may add to a reach to slow "
        "it through a tight spot, as a fraction of its frames", "motion", 0.0, 4.0)

    hand_step_turn: float = _f(
        40.0, "Turn per step", "Greatest turn of the hand relative to the forearm "
        "between neighbouring positions of the smoothed path and between frames, where the "
        "hand is kept continuous. Just over one step of the search's hand samples (35° of "
        "bend): the hand may move to the next sample but never flips across the wrist's "
        "range, which no timing could make smooth", "motion", 5.0, 180.0, "deg")

    hand_lead: float = _f(
        2.0, "Hand lead", "Within this many hand lengths of the target the search turns "
        "the hand toward the one the target needs (where that is not the relaxed hand): "
        "a hand that must tilt to fit at the target, into a drawer or a cubby, tilts "
        "before it goes in rather than getting stuck at the opening. 0 turns it only "
        "when it must", "search", 0.0, 10.0, "hand lengths")

    start_contact_depth: float = _f(
        0.1, "Start contact", "A start pose closer to an obstacle than the "
        "clearance (a hand resting on a table) first moves out of contact, every step "
        "farther from it; it is refused only when the arm's or hand's capsule starts deeper "
        "inside an obstacle than this. About 6 cm on an adult, a hand's thickness: the "
        "capsules stand out of the skin by up to that (a hand's capsule is round, the hand "
        "flat), so a hand lying on a table sinks its capsule that far; a joint inside a "
        "closed obstacle is refused whatever this is", "collision", 0.0, 0.5, "arm lengths")

    # --- collisions -------------------------------------------------------------------------
    clearance: float = _f(0.02, "Clearance", "Margin kept between arm and obstacles "
                          "(at least 0.001 arm lengths, whatever is set: the instants "
                          "between keys as Blender shows them need that hair)",
                          "collision", 0.0, 0.5, "arm lengths")
    check_hand: bool = _f(True, "Check the hand", "Test the hand (wrist to its far end) "
                          "against obstacles and the body too, turning it at the wrist to "
                          "clear them", "collision")
    hand_as_skinned: bool = _f(
        True, "Hand as skinned", "Keep the hand's skin clear, as up to four capsules fitted "
        "to it (a thumb, a flat palm, splayed fingers), rather than one capsule round the "
        "hand's axis, which a thumb or a mitten's edge can stand outside; off, the axis "
        "capsule (a rig without skin has only that)", "collision")

    # --- search (paper, "Guided path planning") --------------------------------------------
    step: float = _f(
        0.02, "Step", "Distance between consecutive wrist positions. The paper's text on it "
        "is lost; Table 2 implies it: path length / nodes in solution = 0.020 arm lengths "
        "in all four tasks", "search", 0.002, 0.2, "arm lengths")
    directions: int = _f(
        26, "Directions", "Directions tried around each node besides the "
        "straight line to the guiding node (evenly spread on a sphere)", "search", 6, 200)
    goal_tolerance: float = _f(0.005, "Goal tolerance", "Wrist within this of the target "
                               "counts as reached", "search", 1e-6, 0.2, "arm lengths")
    blocked_radius: float = _f(
        1.0, "Blocked radius", "Candidate positions within this many steps of a position "
        "the parent node found blocked are tried last (0 = off). One step: moving on from "
        "a node, the step in a direction that was blocked lands one step from the blocked "
        "position, so the search does not run into the same obstacle face at every node",
        "search", 0.0, 4.0, "steps")
    visited_resolution: float = _f(
        0.5, "Visited grid", "Positions closer than this many steps count as "
        "already visited", "search", 0.05, 2.0)
    node_budget: int = _f(4000, "Node budget", "Most wrist positions one search may test",
                          "search", 10, 1000000)
    stall_budget: int = _f(
        800, "Stall budget", "Give up after this many positions without getting closer to "
        "the target", "search", 10, 1000000)
    max_pose_tries: int = _f(
        24, "Poses tried", "Most ranked poses tested for collision at one wrist "
        "position before it is declared blocked", "search", 1, 720)
    guide_when_blocked: bool = _f(
        True, "Guide when blocked", "When an obstacle lies across the straight line from the "
        "wrist to the target (a forearm-thick line), search through the workspace's guiding "
        "nodes first, as the guided reach does, instead of straight at the target: the "
        "straight search would fill the space in front of the obstacle before it found the "
        "way round", "search")
    guided_fallback: bool = _f(
        True, "Other route", "When the best-first search finds no path, search once more "
        "the other way: through the workspace's guiding nodes after a straight search, "
        "straight after a guided one", "search")
    sampling_fallback: bool = _f(
        True, "Sampling fallback", "When the best-first search (both routes, hand kept and "
        "hand free) finds no path to a target some clear pose reaches, search the joint "
        "space with a bidirectional sampling planner (core.sampling), complete in the limit",
        "search")
    sampling_budget: int = _f(
        200000, "Sampling budget", "Most arm states the sampling planner tests for one target "
        "(counted, not timed, so the answer is the same on any machine)", "search",
        100, 10000000)
    sampling_seed: int = _f(0, "Sampling seed", "Seed of the sampling planner's random "
                            "numbers (same seed, same path)", "search", 0, 2 ** 31 - 1)
    sampling_range: float = _f(
        0.15, "Sampling reach", "Longest extension of a sampling tree toward a random state, "
        "in arm lengths of wrist travel (RRT-Connect's range; a few times the step)",
        "search", 0.01, 2.0, "arm lengths")
    sampling_near_share: float = _f(
        0.5, "Share near goal", "Share of the sampling planner's random states drawn "
        "with the wrist near the target (through the IK) rather than uniformly over the "
        "joints: the narrow passage of a reach is where the hand goes in", "search", 0.0, 1.0)
    sampling_path_share: float = _f(
        0.5, "Share on path", "Share of the sampling planner's random "
        "states drawn about the best-first search's path (its poses within a sampling reach, "
        "half of them with the hand turned anywhere), when the search's path is there to "
        "repair: where it fails is usually one hand turn the search left out", "search",
        0.0, 1.0)
    sampling_near_radius: float = _f(
        0.3, "Near radius", "Radius about the target of those wrist positions", "search",
        0.01, 2.0, "arm lengths")
    sampling_goals: int = _f(
        12, "Goal poses", "Most goal configurations (clear IK solutions at the target) the "
        "sampling planner grows its goal tree from", "search", 1, 200)
    sampling_chest_slack: float = _f(
        60.0, "Chest slack", "How far beyond its values at the start and at the target the "
        "sampling planner may turn the chest", "search", 0.0, 180.0, "deg")
    sampling_shortcuts: int = _f(
        100, "Sample shortcuts", "Random shortcut attempts on a sampled path before the "
        "greedy pass", "search", 0, 100000)
    chase_nodes_per_frame: int = _f(
        60, "Chase nodes", "Search budget for each frame of a chase", "search",
        1, 100000)
    chase_max_speed: float = _f(
        2.0, "Chase speed", "Fastest wrist speed while chasing", "search",
        0.05, 20.0, "arm lengths/s")
    chase_plan_ahead: bool = _f(
        True, "Chase plans ahead", "Where following the target frame by frame misses it "
        "(an obstacle the wrist must go round first), catches it only by turning the hand "
        "too fast, plan a reach to where the target ends, taken at the chase's speed, and "
        "wait there; where following it lifts the elbow over a low hand, reach ahead to "
        "where it is later, or ends, and follow it, whichever lifts the elbow least",
        "search")

    # --- workspace (paper, "preprocessing") -------------------------------------------------
    grid_cells: int = _f(11, "Grid cells", "Cells along each side of the workspace grid "
                         "(the paper uses 11)", "workspace", 3, 41)
    guide_radius: float = _f(
        0.5, "Guide radius", "A guiding node counts as passed when the wrist is within this "
        "many cells of it", "workspace", 0.05, 2.0)

    # --- motion ---------------------------------------------------------------------------
    smoothing: bool = _f(True, "Shortcut smoothing", "Replace detours of the search path by "
                         "straight, collision-checked shortcuts", "motion")
    mean_speed: float = _f(
        0.8, "Mean wrist speed", "Automatic duration = path length / this speed",
        "motion", 0.05, 10.0, "arm lengths/s")
    min_duration: float = _f(0.5, "Shortest reach", "Automatic duration is at least this",
                             "motion", 0.0, 60.0, "s")

    # --- the reach envelope (core.envelope; drawn by its own panel, not a planner group) ------
    envelope_body: bool = _f(
        False, "Body classes", "With Lean on, class the points no arm pose reaches by what "
        "of the body would reach them: a lean, a squat, a step. Slow: the balance is "
        "weighed at every such point (minutes on the default grid, against seconds)",
        "envelope")
    envelope_resolution: int = _f(
        13, "Resolution", "Grid points along each side of the reach envelope's cube (13: "
        "2,197 points, about 0.2 arm lengths apart)", "envelope", 2, 41)
    envelope_extent: float = _f(
        1.15, "Extent", "Half the side of the envelope's cube, centred on the shoulder: the "
        "arm, the hand and the chest's turn fit within 1.15", "envelope", 0.1, 3.0,
        "arm lengths")

    # --- the hand oriented to the target (core.orient) -------------------------------------
    match_orientation: bool = _f(
        False, "Match orientation", "The palm arrives aligned with the target's axes (an "
        "Empty's or a mesh's rotation): the finger and palm axes below say which is which; "
        "the error left is reported", "orientation")
    finger_axis: str = _f(
        "+y", "Finger axis", "The target's local axis the fingers point along (wrist to "
        "fingers); with Plain Axes the default +y, with the Single Arrow preset its arrow, +z",
        "orientation", choices=AXES)
    palm_axis: str = _f(
        "-z", "Palm axis", "The target's local axis the palm faces (its outward normal); "
        "default -z: a hand lying on the target's XY plane, palm down", "orientation",
        choices=AXES)
    pronation_max: float = _f(
        80.0, "Pronation limit", "Greatest forearm pronation from neutral (thumb up, elbow "
        "bent 90°) that the palm's roll may use (AAOS: 80°)", "orientation", 0.0, 90.0, "deg")
    supination_max: float = _f(
        80.0, "Supination limit", "Greatest forearm supination from neutral (AAOS: 80°)",
        "orientation", 0.0, 90.0, "deg")
    orientation_tolerance: float = _f(
        10.0, "Tolerance", "The orientation counts as met when the palm's frame "
        "is within this angle of the wanted one", "orientation", 0.1, 90.0, "deg")
    orientation_weight: float = _f(
        100.0, "Weight", "How strongly the hand pass seeks the wanted direction "
        "on the last frames against turning and relaxing the wrist: arriving 45° off costs "
        "this much, a turn at the speed limit 1 a frame", "orientation", 0.0, 1000.0)

    def __post_init__(self):
        validate(self)

    def replace(self, **changes) -> Settings:
        """A copy with some fields changed (validated)."""
        unknown = set(changes) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            raise ReachError(f"unknown setting(s) {sorted(unknown)}; known: {names()}")
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)

    @classmethod
    def from_dict(cls, values: dict) -> Settings:
        """Settings from a mapping, e.g. a preset file or a JSON report (unknown keys are an
        error so that a typo in a preset does not pass silently)."""
        return cls().replace(**dict(values))


def fields():
    """The dataclass fields of :class:`Settings`, with their metadata (label, doc, group,
    min, max, unit, choices)."""
    return dataclasses.fields(Settings)


def names():
    return [f.name for f in fields()]


def validate(settings: Settings) -> None:
    """Check types and ranges of every field; raise :class:`ReachError` naming the field."""
    for f in fields():
        value = getattr(settings, f.name)
        meta = f.metadata
        kind = type(f.default)
        if kind is bool:
            ok = isinstance(value, bool)
        elif kind is int:
            ok = isinstance(value, int) and not isinstance(value, bool)
        elif kind is float:
            ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        else:
            ok = isinstance(value, kind)
        if not ok:
            raise ReachError(f"setting {f.name} must be {kind.__name__}, got {value!r}")
        if "choices" in meta and value not in meta["choices"]:
            raise ReachError(f"setting {f.name} must be one of {meta['choices']}, got {value!r}")
        if kind in (int, float):
            if value != value:  # NaN
                raise ReachError(f"setting {f.name} is NaN")
            if meta["min"] is not None and value < meta["min"]:
                raise ReachError(f"setting {f.name} = {value} is below its minimum {meta['min']}")
            if meta["max"] is not None and value > meta["max"]:
                raise ReachError(f"setting {f.name} = {value} is above its maximum {meta['max']}")
    if settings.alpha_min >= settings.alpha_max or settings.beta_min >= settings.beta_max:
        raise ReachError("shoulder limits: each minimum must be below its maximum")
    if settings.gamma_min >= settings.gamma_max or settings.elbow_min >= settings.elbow_max:
        raise ReachError("twist/elbow limits: each minimum must be below its maximum")
    if settings.finger_axis[1] == settings.palm_axis[1]:
        raise ReachError(f"finger axis {settings.finger_axis} and palm axis {settings.palm_axis} "
                         "must be different axes of the target (perpendicular); e.g. +y and -z")
