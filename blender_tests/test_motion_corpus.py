"""pose.miniskeleton_add_motion on the corpus's rigs that are not Rigify control rigs
(testkit/rig_corpus.py: Mixamo-style humanoids before export and imported again through glTF
and FBX, game rigs exported from an IK set-up (feet and IK targets off the root) and imported
again, the game and hand-made rigs of ../shared/models, a deform-only rig, the generated
creature, and the legless characters): the roles it finds are the rig's anatomy, and walk and
run meet testkit/motion_corpus.py's targets (the mesh moves, every foot planted on the ground
while it stands, a foot down three quarters of the cycle, the skin unfolded, a biped's arms
hanging clear of its body); the head shake keeps the feet still; legless rigs are refused with
"no legs" and nothing keyed. The bare meshes Auto Rig rigs and binds (rig_corpus.AUTORIG: Spot,
always; the scans and the game characters without their armature) walk and run to the same
targets and shake the head bone Auto Rig made.

The expected roles below are each rig's anatomy read off its bones (names where they say it;
CesiumMan's anonymous legs by where they are: its toes point along +X, so its left is +Y).
Rigs whose files are absent (no ../shared) are skipped. Each rig is built once for its tests
(``rig`` is module-scoped)."""

from __future__ import annotations

import math

import bpy
import pytest

from testkit import builders as B

from testkit import motion_corpus as corpus
from testkit import rig_corpus


def _mixamo(side: str) -> tuple[str, str]:
    return f"mixamorig:{side}UpLeg", f"mixamorig:{side}Foot"


MIXAMO = dict(plan="biped", head="mixamorig:Head", neck=["mixamorig:Neck"],
              spine={"mixamorig:Hips", "mixamorig:Spine", "mixamorig:Spine2"},
              legs={"L": _mixamo("Left"), "R": _mixamo("Right")})

# rig: body plan, head, neck, some spine bones, and per leg ("L" / "R", with "front " or "back "
# on quadrupeds): its first bone and a bone it must reach (the foot); the tail's first bone.
EXPECTED = {
    **{name: MIXAMO for name in ("mixamo_blend", "mixamo_gltf", "mixamo_fbx", "mixamo_fbx_xaxis")},
    "deform_only_human": dict(plan="biped", head="head", neck=["neck"], spine={"hips", "spine", "chest"},
                              legs={"L": ("thigh.L", "foot.L"), "R": ("thigh.R", "foot.R")}),
    "creature": dict(plan="quadruped", head="head", neck=["neck"], spine={"spine", "chest"}, tail="tail.001",
                     legs={"front L": ("upper_arm.L", "hand.L"), "front R": ("upper_arm.R", "hand.R"),
                           "back L": ("thigh.L", "foot.L"), "back R": ("thigh.R", "foot.R")}),
    "Fox": dict(plan="quadruped", head="b_Head_05", neck=["b_Neck_04"], spine={"b_Hip_01", "b_Spine02_03"},
                tail="b_Tail01_012",
                legs={"front L": ("b_LeftUpperArm_09", "b_LeftHand_011"),
                      "front R": ("b_RightUpperArm_06", "b_RightHand_08"),
                      "back L": ("b_LeftLeg01_015", "b_LeftFoot01_017"),
                      "back R": ("b_RightLeg01_019", "b_RightFoot01_021")}),
    "CesiumMan": dict(plan="biped", head="Node_20", neck=["Node_19"], spine={"Node_2", "Node_12"},
                      legs={"L": ("Node_7", "Node_9"), "R": ("Node_3", "Node_5")}),
    "RobotExpressive": dict(plan="biped", head="Head", neck=["Neck"], spine={"Hips", "Torso"},
                            legs={"L": ("UpperLeg.L", "Foot.L"), "R": ("UpperLeg.R", "Foot.R")}),
    "q_Bunny": dict(plan="biped", head="Head", neck=["Neck"], spine={"Hips", "Torso"},
                    legs={"L": ("UpperLeg.L", "Foot.L"), "R": ("UpperLeg.R", "Foot.R")}),
    "ik_quadruped_gltf": dict(plan="quadruped", head="Head", neck=["Neck"], spine={"Hips", "Spine", "Chest"},
                              tail="Tail",
                              legs={f"{where} {s}": (first + s, toe + s)
                                    for where, first, toe in (("front", "UpperArm.", "FrontToe."),
                                                              ("back", "Thigh.", "HindToe."))
                                    for s in "LR"}),
    "ik_biped_gltf": dict(plan="biped", head="Head", neck=["Neck"], spine={"Hips", "Spine", "Spine2"},
                          legs={"L": ("LeftUpLeg", "LeftToeBase"), "R": ("RightUpLeg", "RightToeBase")}),
    "spot_rig": dict(plan="quadruped", head="head", neck=["neck_root", "neck_mid"], spine={"body_root", "body_back"},
                     tail="tail",
                     legs={"front L": ("leg_front_L_hip", "leg_front_L_ankle"),
                           "front R": ("leg_front_R_hip", "leg_front_R_ankle"),
                           "back L": ("leg_back_L_hip", "leg_back_L_ankle"),
                           "back R": ("leg_back_R_hip", "leg_back_R_ankle")}),
}
LEGLESS = [name for name in rig_corpus.NAMES if name.startswith("q_") and name not in EXPECTED]
AUTORIG = list(rig_corpus.AUTORIG)
BIPEDS = [name for name in EXPECTED if EXPECTED[name]["plan"] == "biped"] + ["autorig_CesiumMan"]
# Clips whose skin still folds past the targets, and why (bench/fold_causes.py binds the same
# skeleton four ways: its own weights, our Heat, Blender's bone heat, nearest segments, and
# counts the vertices torn from their copies). Strict: each fails the day it passes.
KNOWN_FOLDS: dict = {}
# Clips whose feet do not meet the targets yet, and why. Strict: each fails the day it passes.
KNOWN_SLIPS: dict = {}


@pytest.fixture(autouse=True)
def clean_scene():
    """Overrides conftest's: rigs are built once per module (``built``), not per test."""
    yield


def built(name: str) -> rig_corpus.Rig:
    """Rig ``name`` (``builders.corpus_rig``); skipped when its file is absent."""
    why = rig_corpus.missing(name)
    if why:
        pytest.skip(why)
    return B.corpus_rig(name)


def roles_of(arm) -> tuple[dict, list[str]]:
    """The roles the operator plans with (the core's, on the add-on's motion skeleton)."""
    planning = B.addon("motion.planning")
    scene = bpy.context.scene
    bones = planning.motion_bones(arm)
    out = planning.make_motion(arm, bones, scene, scene.render.fps / scene.render.fps_base, "HEAD_SHAKE",
                               cycles=2.0, duration=1.5, amplitude=math.radians(30), stride=1.0, speed=1.0,
                               root_motion=True)
    return out.roles, list(bones.names)


def leg_label(leg: dict, groups: int) -> str:
    where = ("front " if leg.group == 0 else "back ") if groups > 1 else ""
    return where + leg.side


@pytest.mark.parametrize("name", list(EXPECTED))
def test_the_roles_are_the_rigs_anatomy(name):
    r = built(name)
    want = EXPECTED[name]
    roles, names = roles_of(r.arm)
    assert roles.plan == want["plan"]
    assert names[roles.head] == want["head"]
    assert [names[b] for b in roles.neck] == want["neck"]
    assert want["spine"] <= {names[b] for b in roles.spine}, [names[b] for b in roles.spine]
    assert names[roles.tail[0]] == want["tail"] if "tail" in want else not roles.tail
    groups = max(leg.group for leg in roles.legs) + 1
    found = {leg_label(leg, groups): [names[b] for b in leg.bones] for leg in roles.legs}
    assert set(found) == set(want["legs"]), found
    for label, (first, foot) in want["legs"].items():
        assert found[label][0] == first and foot in found[label], (label, found[label])


@pytest.fixture(scope="module", params=list(EXPECTED) + AUTORIG)
def rig(request):
    return request.param


_rows: dict = {}


def clip(rig: str, motion: str) -> dict:
    """``motion_corpus.run_motion``'s row for ``rig`` and ``motion``, measured once per module."""
    if (rig, motion) not in _rows:
        r = built(rig)
        _rows[rig, motion] = corpus.run_motion(r.arm, r.meshes, motion, r.basis)
    return _rows[rig, motion]


@pytest.mark.parametrize("motion", ["WALK", "RUN"])
def test_walk_and_run_move_the_mesh_with_every_foot_standing_on_the_ground(rig, motion, request):
    """Feet planted (no skate), on the ground (no float, no sinking), each foot standing on the
    ground while it stands (Spot's hind hooves, 7 % of its size above its front ones at rest,
    settle onto it), and a foot on the ground three quarters of the cycle or more."""
    if (rig, motion) in KNOWN_SLIPS:
        request.applymarker(pytest.mark.xfail(reason=KNOWN_SLIPS[rig, motion], strict=True))
    row = clip(rig, motion)
    assert row["result"] == "FINISHED", row["error"]
    t = corpus.TARGET
    assert row["moves"] >= t["moves"] and row["deform"] >= t["inert"], row
    assert row["pen"] <= t["pen"], row["pen"]
    assert row["skate"] <= t["skate"] and abs(row["float"]) <= t["float"], (row["skate"], row["float"])
    assert row["stance"] <= t["stance"] and row["contact"] >= t["contact"], (row["stance"], row["contact"])


@pytest.mark.parametrize("motion", ["WALK", "RUN"])
def test_walk_and_run_keep_the_skin_from_folding(rig, motion, request):
    """On the largest mesh, the worst frame's change of enclosed volume and share of triangles
    collapsed below a quarter of their area stay within the artist's own clips' (the Fox's):
    5 % and 0.4 % walking, 10 % and 1.5 % running."""
    if (rig, motion) in KNOWN_FOLDS:
        request.applymarker(pytest.mark.xfail(reason=KNOWN_FOLDS[rig, motion], strict=True))
    row = clip(rig, motion)
    most_volume, most_collapsed = corpus.FOLDS[motion]
    assert row["volume"] <= most_volume and row["collapsed"] <= most_collapsed, (row["volume"], row["collapsed"])


@pytest.mark.parametrize("motion", ["WALK", "RUN"])
@pytest.mark.parametrize("biped", BIPEDS)
def test_a_bipeds_arms_hang_and_swing_clear_of_its_body(biped, motion):
    """T- and A-posed arms walk hanging within 30 degrees of straight down, swinging against the
    legs; running, the elbows bend; no hand goes into the torso."""
    row = clip(biped, motion)
    t = corpus.TARGET
    assert row["hand_in"] <= t["hand_in"], row["hand_in"]
    if motion == "WALK":
        assert row["hang"] <= t["hang"] and row["swing"] >= t["swing"], (row["hang"], row["swing"])
        assert row["against"] < t["against"], row["against"]
    else:
        assert row["elbow"] >= t["elbow"], row["elbow"]


def test_head_shake_turns_the_head_and_keeps_the_feet_still(rig):
    r = built(rig)
    row = corpus.run_motion(r.arm, r.meshes, "HEAD_SHAKE", r.basis)
    assert row["result"] == "FINISHED", row["error"]
    if rig in EXPECTED:
        assert row.get("head_bone") == EXPECTED[rig]["head"], row["info"]
    else:   # an auto-rigged one shakes a bone of Auto Rig's trunk (spine.*), not a limb's
        assert str(row.get("head_bone")).startswith("spine"), row["info"]
    assert row["head"] >= corpus.TARGET["head"] and row["feet"] < corpus.TARGET["feet"], row


@pytest.mark.parametrize("name", AUTORIG)
def test_an_auto_rigged_mesh_is_bound_with_every_vertex_weighted(name):
    r = built(name)
    assert r.kind == "auto-rigged" and r.meshes
    assert rig_corpus.unweighted(r.arm, r.meshes) == 0


@pytest.mark.parametrize("name", LEGLESS)
def test_a_legless_rig_is_refused_no_legs_with_nothing_keyed_and_shakes_its_head(name):
    r = built(name)
    for motion in ("WALK", "RUN"):
        row = corpus.run_motion(r.arm, r.meshes, motion, r.basis)
        assert row["result"] == "CANCELLED" and "no legs" in (row["error"] or ""), row["error"]
        assert not row["keyed_any"]
    row = corpus.run_motion(r.arm, r.meshes, "HEAD_SHAKE", r.basis)
    assert row["result"] == "FINISHED" and row["head"] >= corpus.TARGET["head"], row
    B.set_active(r.arm)


# ---------------------------------------------------------------------------- steering

STEERED = ["ik_biped_gltf", "ik_quadruped_gltf"]


@pytest.mark.parametrize("case", ["circle", "s_curve", "slope", "bumps", "step", "in_place"])
@pytest.mark.parametrize("name", STEERED)
def test_a_steered_walk_keeps_its_feet_planted_on_the_ground_and_heads_along_the_path(name, case):
    """testkit/motion_corpus.py's steering rows (``steer_row``): along a half circle of radius 2
    body lengths and an S-curve, up a 15 degree slope, over bumps and up a step of 15 % of the
    leg: no skate in the ground's frame, each standing foot on the surface under it, nothing
    through it, the body turning with the path; in place, no travel."""
    row = corpus.steer_row(built(name), case)
    assert row["result"] == "FINISHED", row["error"]
    t = corpus.STEER_TARGET
    assert row["pen"] <= t["pen"], row["pen"]
    if case == "in_place":   # the feet slide back under a body that stays: no foot stands
        assert row["travel"] <= t["travel"], row["travel"]
    else:
        assert row["skate"] <= t["skate"] and abs(row["stance"]) <= t["stance"], (row["skate"], row["stance"])
    if "heading" in row:
        assert row["heading"] <= t["heading"], row["heading"]


def test_a_bad_path_or_ground_is_one_report_and_nothing_is_keyed():
    """A path of one point, far from the character, or not a curve; a ground that is the
    armature itself or not a mesh; In Place with a path: each an error naming it, no key."""
    r = built("ik_biped_gltf")
    one = bpy.data.curves.new("one_point", "CURVE")
    one.splines.new("POLY")
    far = bpy.data.curves.new("far", "CURVE")
    sp = far.splines.new("POLY")
    sp.points.add(1)
    sp.points[0].co, sp.points[1].co = (1e3, 0, 0, 1), (1e3 + 5, 0, 0, 1)
    near = bpy.data.curves.new("near", "CURVE")
    sp = near.splines.new("POLY")
    sp.points.add(1)
    sp.points[0].co, sp.points[1].co = (*r.arm.location[:2], 0, 1), (r.arm.location.x + 5, r.arm.location.y, 0, 1)
    obs = [bpy.data.objects.new(c.name, c) for c in (one, far, near)]
    for ob in obs:
        bpy.context.scene.collection.objects.link(ob)
    cases = [(dict(path="one_point"), "two points"), (dict(path="far"), "starts"),
             (dict(path=r.arm.name), "not a curve"), (dict(ground=r.arm.name), "not a mesh"),
             (dict(ground=r.meshes[0].name), "part of the character"),
             (dict(path="near", in_place=True), "In Place"), (dict(path="nothing"), "no object")]
    try:
        for props, why in cases:
            corpus.reset_rig(r.arm, r.basis)
            B.set_active(r.arm)
            with pytest.raises(RuntimeError, match=why):
                bpy.ops.pose.miniskeleton_add_motion(motion="WALK", **props)
            assert not corpus.keyed_anything(r.arm), props
    finally:
        for ob in obs:
            data = ob.data
            bpy.data.objects.remove(ob)
            bpy.data.curves.remove(data)
