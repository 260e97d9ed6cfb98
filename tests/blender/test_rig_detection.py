"""The rig adapter (``blender/rig.py``) finds the arms, the chest and the body frame.

Synthetic humanoids (``synthetic.py``: a 1.75 m adult in an A-pose under many naming
conventions, turned, scaled, lying down, with decoy chains) test that detection depends on
the skeleton and not on one naming scheme or orientation; the five real test rigs
(``rigs.py``, facts from the rig survey) test it on files as they come from other tools.
"""

from __future__ import annotations

import re

import bpy
import numpy as np
import pytest
import rigs
import synthetic as syn

NAMED = ("mixamo", "vrm", "unity", "spaced", "makehuman", "unreal", "plain")
# How each map is built by default: the Unreal mannequin has its twist bones; numbered rigs
# (Blender's default names) have no clavicle.
BUILD = {"unreal": {"twist": True}, "numbered": {"clavicle": False}}

# Facing / lying → the character's right, forward and up in world space, by construction.
AXES = {
    ("-Y", False): ((-1, 0, 0), (0, -1, 0), (0, 0, 1)),
    ("+Y", False): ((1, 0, 0), (0, 1, 0), (0, 0, 1)),
    ("-Y", True): ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
    ("+Y", True): ((1, 0, 0), (0, 0, 1), (0, -1, 0)),
}

def with_numbered(keys=NAMED):
    return [*keys, "numbered"]


@pytest.fixture
def rig(addon):
    return addon.blender.rig


@pytest.fixture
def rig_detect(addon):
    return addon.blender.rig_detect


@pytest.fixture
def skin(addon):
    return addon.blender.skin


@pytest.fixture
def body_frame(addon):
    return addon.blender.body_frame


@pytest.fixture
def ReachError(addon):
    return addon.core.ReachError


def build_map(key, **kw):
    names = syn.MAPS[key]
    return syn.humanoid(names, **{**BUILD.get(key, {}), **kw}), names


def expected_bones(names, *, clavicle=True, keys=None):
    """What ``BoneMap.to_dict()`` must give: the chest and, per side, the clavicle (the upper
    arm's own parent: MakeHuman's ``shoulder01``, which runs from the short ``clavicle``
    stub at the neck to the shoulder joint), upper arm, forearm and hand. ``keys`` maps
    roles to the decoy naming that should get the keys instead (``"driver"``)."""
    out = {"chest": names["chest"]}
    for side, tag in (("right", "R"), ("left", "L")):
        clav = names.get(f"shoulder_{tag}", names.get(f"clavicle_{tag}"))
        out[f"clavicle_{side}"] = clav if clavicle else None
        for role in ("upper_arm", "forearm", "hand"):
            out[f"{role}_{side}"] = (syn.decoy_name(names, keys, role, tag) if keys
                                     else names[f"{role}_{tag}"])
    return out


def angle(a, b) -> float:
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    c = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def assert_axes(frame, right, forward, up, tol=5.0):
    got = {"right": frame.right, "forward": frame.forward, "up": frame.up}
    want = {"right": right, "forward": forward, "up": up}
    off = {k: round(angle(got[k], want[k]), 2) for k in got}
    assert max(off.values()) < tol, f"body axes off by {off}°: got " + \
        str({k: np.round(v, 3).tolist() for k, v in got.items()})


def assert_synthetic_frame(info, *, facing="-Y", lying=False, side="right"):
    """Body axes, origin and the arm's joints exactly where the construction put them."""
    assert_axes(info.frame, *AXES[facing, lying])

    def world(p):
        return syn.to_world(p, facing=facing, lying=lying)

    np.testing.assert_allclose(info.frame.origin, world((0, 0, syn.SHOULDER_Z)), atol=1e-4)
    assert info.frame.shoulder_half_width == pytest.approx(syn.SHOULDER_HALF_WIDTH, abs=1e-4)
    joints = syn.arm_joints("R" if side == "right" else "L")
    for joint in ("shoulder", "elbow", "wrist"):
        np.testing.assert_allclose(info.joints_world[joint], world(joints[joint]), atol=1e-4,
                                   err_msg=f"{side} {joint}")
    assert info.side == side
    assert info.arm.upper_arm_length == pytest.approx(syn.ARM_LENGTHS[0], abs=1e-4)
    assert info.arm.arm_length == pytest.approx(sum(syn.ARM_LENGTHS), abs=1e-4)


# --- synthetic rigs: names ---------------------------------------------------------------------

@pytest.mark.parametrize("key", with_numbered())
def test_detects_arms_chest_and_body_frame(fresh, rig, rig_detect, key):
    arm, names = build_map(key)
    bmap = rig_detect.detect_bones(arm)
    assert bmap.to_dict() == expected_bones(names, clavicle=key != "numbered")
    assert bmap.neck == names["neck"]
    assert bmap.ik_fk == {}
    assert_synthetic_frame(rig.build(arm, "right"))
    assert_synthetic_frame(rig.build(arm, "left"), side="left")


@pytest.mark.parametrize("key", with_numbered(("mixamo", "unity", "plain", "makehuman")))
def test_clavicle_is_optional(fresh, rig, rig_detect, key):
    arm, names = build_map(key, clavicle=False)
    assert rig_detect.detect_bones(arm).to_dict() == expected_bones(names, clavicle=False)
    assert_synthetic_frame(rig.build(arm, "right"))


def test_numbered_rig_with_clavicles(fresh, rig_detect):
    """A short first bone followed by a long one is taken as the clavicle."""
    arm, names = build_map("numbered", clavicle=True)
    assert rig_detect.detect_bones(arm).to_dict() == expected_bones(names)


@pytest.mark.parametrize("key", ("mixamo", "vrm", "plain", "unreal", "makehuman", "numbered"))
def test_twist_bones_are_not_arm_joints(fresh, rig, rig_detect, key):
    arm, names = build_map(key, twist=True)
    twists = [b.name for b in arm.data.bones if b.name.endswith("_twist") or "twist_01" in b.name]
    assert len(twists) == 4
    clavicle = BUILD.get(key, {}).get("clavicle", True)
    assert rig_detect.detect_bones(arm).to_dict() == expected_bones(names, clavicle=clavicle)
    assert_synthetic_frame(rig.build(arm, "right"))


@pytest.mark.parametrize("key", with_numbered())
def test_names_suffice_without_skin(fresh, rig, skin, rig_detect, key):
    arm, names = build_map(key, skin=False)
    assert not skin.skin_bones(arm)
    assert rig_detect.detect_bones(arm).to_dict() == expected_bones(names, clavicle=key != "numbered")
    assert_synthetic_frame(rig.build(arm, "right"))


# --- synthetic rigs: orientation and scale ----------------------------------------------------

@pytest.mark.parametrize("facing, lying", (("+Y", False), ("-Y", True), ("+Y", True)))
@pytest.mark.parametrize("key", with_numbered())
def test_body_frame_follows_the_rig(fresh, rig, rig_detect, key, facing, lying):
    """Nothing about orientation is assumed: the frame comes out of the bones whether the
    object is turned round or the rest pose itself lies on its back (up +Y, front +Z)."""
    arm, names = build_map(key, facing=facing, lying=lying)
    assert rig_detect.detect_bones(arm).to_dict() == expected_bones(names, clavicle=key != "numbered")
    assert_synthetic_frame(rig.build(arm, "right"), facing=facing, lying=lying)
    assert_synthetic_frame(rig.build(arm, "left"), facing=facing, lying=lying, side="left")


@pytest.mark.parametrize("scale", (0.01, 100.0))
@pytest.mark.parametrize("key", with_numbered(("mixamo", "makehuman", "unreal")))
def test_scaled_armature_is_measured_in_world_units(fresh, rig, rig_detect, key, scale):
    """Object scale 0.01 with bones 100× longer (an FBX from centimetres) is the same figure:
    every length, radius and joint of the arm model equals the unscaled rig's."""
    plain = rig.build(build_map(key)[0], "right")
    bpy.ops.wm.read_homefile(use_empty=True)
    arm, names = build_map(key, scale=scale)
    assert rig_detect.detect_bones(arm).to_dict() == expected_bones(names, clavicle=key != "numbered")
    info = rig.build(arm, "right")
    assert_synthetic_frame(info)
    for attr in ("upper_arm_length", "forearm_length", "hand_length", "upper_arm_radius",
                 "forearm_radius", "hand_radius", "arm_length"):
        assert getattr(info.arm, attr) == pytest.approx(getattr(plain.arm, attr), rel=1e-4), attr
    for attr in ("sternum", "shoulder", "waist"):
        np.testing.assert_allclose(getattr(info.arm, attr), getattr(plain.arm, attr), atol=1e-4)
    assert info.frame.shoulder_half_width == pytest.approx(plain.frame.shoulder_half_width, rel=1e-4)


# --- decoys -----------------------------------------------------------------------------------

@pytest.mark.parametrize("decoy", ("ik", "twin"))
@pytest.mark.parametrize("key", NAMED)
def test_skin_chain_beats_a_decoy_on_the_same_joints(fresh, rig, rig_detect, key, decoy):
    """An IK-style chain, or one named just as well (and first by name), lying exactly on the
    arm: the chain that moves the skin is the arm, and it keeps its own keys."""
    arm, names = build_map(key, decoy=decoy)
    decoys = {syn.decoy_name(names, decoy, "upper_arm", t) for t in syn.SIDES}
    assert decoys <= set(arm.data.bones.keys())
    bmap = rig_detect.detect_bones(arm)
    assert bmap.to_dict() == expected_bones(names)
    assert all(a.key == {} for a in bmap.arms.values())
    assert_synthetic_frame(rig.build(arm, "right"))


@pytest.mark.parametrize("key", NAMED)
def test_controls_driving_the_skin_chain_get_the_keys(fresh, rig, rig_detect, key):
    """Deform bones that Copy Transforms from a control chain on the same joints: the joints
    are read from the deform chain, the keys go to the controls."""
    arm, names = build_map(key, decoy="driver")
    bmap = rig_detect.detect_bones(arm)
    assert bmap.to_dict() == expected_bones(names, keys="driver")
    for side, tag in (("right", "R"), ("left", "L")):
        a = bmap.arms[side]
        assert (a.upper_arm, a.forearm, a.hand) == tuple(names[f"{r}_{tag}"]
                                                        for r in ("upper_arm", "forearm", "hand"))
    assert bmap.keyed_chest == names["chest"]
    assert_synthetic_frame(rig.build(arm, "right"))


def test_a_muted_or_partial_constraint_does_not_hand_over_the_keys(fresh, rig_detect):
    arm, names = build_map("plain", decoy="driver")
    arm.pose.bones[names["upper_arm_R"]].constraints[0].mute = True
    arm.pose.bones[names["forearm_R"]].constraints[0].influence = 0.5
    d = rig_detect.detect_bones(arm).to_dict()
    assert (d["upper_arm_right"], d["forearm_right"], d["hand_right"]) == \
        (names["upper_arm_R"], names["forearm_R"], "c_hand.R")
    assert d["upper_arm_left"] == "c_upper_arm.L"


# --- overrides --------------------------------------------------------------------------------

def test_overrides_win_over_detection(fresh, rig, rig_detect):
    arm, names = build_map("plain", decoy="ik")
    chain = {"upper_arm_right": "upper_arm_ik.R", "forearm_right": "forearm_ik.R",
             "hand_right": "hand_ik.R"}
    expected = {**expected_bones(names), **chain}
    assert rig_detect.detect_bones(arm, chain).to_dict() == expected
    assert rig_detect.detect_bones(arm, {**chain, "chest": "Spine"}).to_dict() == \
        {**expected, "chest": "Spine"}
    info = rig.build(arm, "right", overrides=chain)
    assert info.bones.to_dict() == expected
    assert_synthetic_frame(info)   # the IK chain lies on the same joints


def test_override_beats_a_driving_control(fresh, rig_detect):
    arm, names = build_map("mixamo", decoy="driver")
    d = rig_detect.detect_bones(arm, {"upper_arm_right": names["upper_arm_R"]}).to_dict()
    assert d["upper_arm_right"] == names["upper_arm_R"]
    assert (d["forearm_right"], d["hand_right"], d["upper_arm_left"]) == \
        ("c_forearm.R", "c_hand.R", "c_upper_arm.L")


def test_empty_overrides_are_ignored(fresh, rig_detect):
    arm, names = build_map("vrm")
    bmap = rig_detect.detect_bones(arm, {"upper_arm_right": "", "chest": None})
    assert bmap.to_dict() == expected_bones(names)


# --- errors -----------------------------------------------------------------------------------

TELLS_WHAT_TO_DO = re.compile(r"\b(set|pick|choose|clear|check)\b")


def test_unknown_override_bone_is_a_reach_error(fresh, rig, rig_detect, ReachError):
    arm, _names = build_map("unity")
    for call in (lambda: rig_detect.detect_bones(arm, {"hand_right": "NoSuchBone"}),
                 lambda: rig.build(arm, "right", overrides={"hand_right": "NoSuchBone"})):
        with pytest.raises(ReachError) as err:
            call()
        msg = str(err.value)
        assert "NoSuchBone" in msg and f"'{arm.name}'" in msg and "hand" in msg, msg
        assert TELLS_WHAT_TO_DO.search(msg), msg


def test_overrides_that_are_not_a_chain_are_a_reach_error(fresh, rig_detect, ReachError):
    arm, names = build_map("mixamo")
    with pytest.raises(ReachError) as err:
        rig_detect.detect_bones(arm, {"forearm_right": names["forearm_L"]})
    msg = str(err.value)
    assert f"'{arm.name}'" in msg and names["forearm_L"] in msg and "right" in msg, msg
    assert TELLS_WHAT_TO_DO.search(msg), msg


@pytest.mark.parametrize("bones, missing", (
    (("Bone", "Bone.001", "Bone.002"), "right or left"),
    (("upper_arm.R", "forearm.R", "hand.R"), "left"),
))
def test_armature_without_arms_is_a_reach_error(fresh, rig, rig_detect, ReachError, bones, missing):
    arm = syn.bone_chain(bones, name="Stick")
    for call in (lambda: rig_detect.detect_bones(arm), lambda: rig.build(arm, "right")):
        with pytest.raises(ReachError) as err:
            call()
        msg = str(err.value)
        assert "'Stick'" in msg and f"{missing} arm" in msg, msg
        assert TELLS_WHAT_TO_DO.search(msg), msg


def test_not_an_armature_is_a_reach_error(fresh, rig, ReachError):
    mesh = bpy.data.objects.new("Crate", bpy.data.meshes.new("Crate"))
    bpy.context.scene.collection.objects.link(mesh)
    with pytest.raises(ReachError, match="'Crate'.*not an armature"):
        rig.build(mesh)
    with pytest.raises(ReachError, match="no armature"):
        rig.build(None)


# --- the real rigs ----------------------------------------------------------------------------

def _sides(chest, right, left):
    out = {"chest": chest}
    for side, bones in (("right", right), ("left", left)):
        out.update(zip((f"{r}_{side}" for r in ("clavicle", "upper_arm", "forearm", "hand")), bones))
    return out


def _metarig_names(pre="", fk=""):
    return {side: (f"{pre}shoulder.{t}", f"{pre}upper_arm{fk}.{t}", f"{pre}forearm{fk}.{t}",
                   f"{pre}hand{fk}.{t}") for side, t in (("right", "R"), ("left", "L"))}


_MR, _FK = _metarig_names(), _metarig_names(fk="_fk")
REAL_BONES = {
    "cesium": _sides("torso_joint_3",
                     (None, "Skeleton_arm_joint_R", "Skeleton_arm_joint_R__2_", "Skeleton_arm_joint_R__3_"),
                     (None, "Skeleton_arm_joint_L__4_", "Skeleton_arm_joint_L__3_",
                      "Skeleton_arm_joint_L__2_")),
    "quaternius": _sides("Torso", ("Shoulder.R", "UpperArm.R", "LowerArm.R", "Palm.R"),
                         ("Shoulder.L", "UpperArm.L", "LowerArm.L", "Palm.L")),
    "gomakehuman": _sides("chest1", ("shoulder.R", "upper_arm.R", "forearm.R", "hand.R"),
                          ("shoulder.L", "upper_arm.L", "forearm.L", "hand.L")),
    "metarig": _sides("spine.003", _MR["right"], _MR["left"]),
    # keyed: the FK controls, the shoulder control and the torso's chest control
    "rigify": _sides("chest", _FK["right"], _FK["left"]),
}
# Rest-pose world heads of the right shoulder, elbow and wrist (rig survey, 3 decimals).
REAL_JOINTS = {
    "cesium": ((-0.086, 0.004, 1.074), (-0.301, 0.016, 0.965), (-0.445, -0.067, 0.875)),
    "quaternius": ((-0.453, 0.022, 3.668), (-1.13, 0.085, 3.609), (-1.903, 0.085, 3.651)),
    "gomakehuman": ((-0.171, -0.02, 1.331), (-0.334, -0.021, 1.149), (-0.456, -0.185, 1.024)),
    "metarig": ((-0.195, 0.027, 1.585), (-0.442, 0.089, 1.449), (-0.659, 0.049, 1.306)),
    "rigify": ((-0.195, 0.027, 1.585), (-0.442, 0.089, 1.449), (-0.659, 0.049, 1.306)),
}


@pytest.mark.parametrize("kind", rigs.RIGS)
def test_real_rig_bones(addon, rig_detect, kind):
    arm = rigs.load(kind)
    bmap = rig_detect.detect_bones(arm)
    assert bmap.to_dict() == REAL_BONES[kind]
    if kind == "rigify":
        # joints are read from the ORG chain; keys go to the FK controls with the switch at FK
        right = bmap.arms["right"]
        assert (right.clavicle, right.upper_arm, right.forearm, right.hand) == _metarig_names("ORG-")["right"]
        assert bmap.chest == "ORG-spine.003"
        assert bmap.ik_fk == {"right": ("upper_arm_parent.R", "IK_FK"),
                              "left": ("upper_arm_parent.L", "IK_FK")}
    else:
        assert bmap.ik_fk == {}


@pytest.mark.parametrize("kind", rigs.RIGS)
def test_real_rig_faces_minus_y_with_right_at_minus_x(addon, rig, kind):
    """All five rigs face −Y with the character's right at −X in world space (CesiumMan's
    armature space is rotated under a Z-up empty). The spines lean up to ~7° (Quaternius's
    hips-to-head line tilts back), hence the looser tolerance than for synthetic rigs."""
    arm = rigs.load(kind)
    rigs.rest_still(arm)
    info = rig.build(arm, "right")
    assert_axes(info.frame, (-1, 0, 0), (0, -1, 0), (0, 0, 1), tol=10.0)
    for joint, want in zip(("shoulder", "elbow", "wrist"), REAL_JOINTS[kind]):
        np.testing.assert_allclose(info.joints_world[joint], want, atol=2e-3, err_msg=joint)
    shoulder, elbow, wrist = np.array(REAL_JOINTS[kind])
    length = np.linalg.norm(elbow - shoulder) + np.linalg.norm(wrist - elbow)
    assert info.arm.arm_length == pytest.approx(length, abs=5e-3)


def test_rigify_switch_at_fk_lets_the_keyed_controls_move_the_arm(addon, rig_detect, body_frame):
    """Setting the recorded IK_FK switch to 1 (FK) makes the keyed FK upper arm drive the
    joints Reach reads (the ORG hand); at 0 (IK, Rigify's default) it does not."""
    from mathutils import Quaternion

    arm = rigs.load("rigify")
    bmap = rig_detect.detect_bones(arm)
    bone, prop = bmap.ik_fk["right"]
    upper = arm.pose.bones[bmap.arms["right"].keyed("upper_arm")]
    hand = bmap.arms["right"].hand

    def hand_moves(switch):
        arm.pose.bones[bone][prop] = switch
        upper.rotation_quaternion = (1, 0, 0, 0)
        arm.update_tag()
        bpy.context.view_layer.update()
        before = body_frame.pose_heads(arm, [hand])[hand]
        upper.rotation_quaternion = Quaternion((1, 0, 0), np.radians(60))
        arm.update_tag()
        bpy.context.view_layer.update()
        return float(np.linalg.norm(body_frame.pose_heads(arm, [hand])[hand] - before))

    assert hand_moves(1.0) > 0.1
    assert hand_moves(0.0) < 1e-4
