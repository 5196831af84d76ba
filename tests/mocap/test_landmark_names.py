"""Landmark tables for the circulating naming conventions, user mappings, the no-match error."""

import tomllib
from pathlib import Path

import pytest
from mocap_synth import arms_down, mini_bvh

from motionkit.mocap import LANDMARKS, MocapError, load_mocap, mapping_template
from motionkit.mocap.naming import normalise, resolve

HERE = Path("skeleton.bvh")

CMU_ASF = ["root", "lhipjoint", "lfemur", "ltibia", "lfoot", "ltoes", "ltoes_end", "rhipjoint",
           "rfemur", "rtibia", "rfoot", "rtoes", "rtoes_end", "lowerback", "upperback", "thorax",
           "lowerneck", "upperneck", "head", "head_end", "lclavicle", "lhumerus", "lradius",
           "lwrist", "rclavicle", "rhumerus", "rradius", "rwrist"]  # fmt: skip
BIOVISION = ["Hips", "LeftHip", "LeftKnee", "LeftAnkle", "LeftAnkle_End", "RightHip", "RightKnee",
             "RightAnkle", "RightAnkle_End", "Chest", "Neck", "Head", "Head_End", "LeftCollar",
             "LeftShoulder", "LeftElbow", "LeftWrist", "RightCollar", "RightShoulder",
             "RightElbow", "RightWrist"]  # fmt: skip
UPARM = ["Hips", "LeftUpLeg", "LeftLowLeg", "LeftFoot", "LeftFoot_End", "RightUpLeg",
         "RightLowLeg", "RightFoot", "RightFoot_End", "Chest", "Neck", "Head", "LeftCollar",
         "LeftUpArm", "LeftLowArm", "LeftHand", "RightCollar", "RightUpArm", "RightLowArm",
         "RightHand"]  # fmt: skip
DAZ = ["hip", "abdomen", "chest", "neck", "head", "head_End", "lCollar", "lShldr", "lForeArm",
       "lHand", "rCollar", "rShldr", "rForeArm", "rHand", "lThigh", "lShin", "lFoot", "lFoot_End",
       "rThigh", "rShin", "rFoot", "rFoot_End"]  # fmt: skip


def test_cmu_asf_names() -> None:
    found = resolve(CMU_ASF, None, HERE)
    assert tuple(found) == LANDMARKS
    expected = {"pelvis": "root", "l_hip": "lfemur", "l_knee": "ltibia", "l_ankle": "lfoot",
                "l_toe": "ltoes", "spine": "upperback", "chest": "thorax", "neck": "lowerneck",
                "head": "head_end", "r_shoulder": "rhumerus", "r_elbow": "rradius",
                "r_wrist": "rwrist"}  # fmt: skip
    assert {k: found[k] for k in expected} == expected


def test_biovision_collar_shoulder_elbow() -> None:
    found = resolve(BIOVISION, None, HERE)
    assert found["l_shoulder"] == "LeftShoulder" and found["l_elbow"] == "LeftElbow"
    assert found["l_wrist"] == "LeftWrist" and found["r_hip"] == "RightHip"
    assert found["l_toe"] == "LeftAnkle_End" and found["chest"] == "Chest"
    assert "spine" not in found  # approximated


def test_biovision_uparm_lowarm() -> None:
    found = resolve(UPARM, None, HERE)
    assert found["l_shoulder"] == "LeftUpArm" and found["l_elbow"] == "LeftLowArm"
    assert found["l_wrist"] == "LeftHand" and found["l_knee"] == "LeftLowLeg"
    assert found["l_ankle"] == "LeftFoot" and found["l_toe"] == "LeftFoot_End"
    assert found["head"] == "Head"


def test_daz_names() -> None:
    found = resolve(DAZ, None, HERE)
    assert found["pelvis"] == "hip" and found["l_hip"] == "lThigh" and found["r_knee"] == "rShin"
    assert found["l_shoulder"] == "lShldr" and found["spine"] == "abdomen"
    assert found["head"] == "head_End" and found["r_toe"] == "rFoot_End"


def test_names_compare_loosely() -> None:
    assert normalise("mixamorig:Left_Up-Leg") == normalise("LEFT UP LEG") == "leftupleg"
    names = [f"mixamorig:{n}" for n in ("Hips", "LeftUpLeg", "LeftLeg", "LeftFoot", "LeftToeBase",
             "RightUpLeg", "RightLeg", "RightFoot", "RightToeBase", "Spine", "Spine1", "Spine2",
             "Neck", "Head", "HeadTop_End", "LeftShoulder", "LeftArm", "LeftForeArm", "LeftHand",
             "RightShoulder", "RightArm", "RightForeArm", "RightHand")]  # fmt: skip
    found = resolve(names, None, HERE)
    assert found["chest"] == "mixamorig:Spine2" and found["head"] == "mixamorig:HeadTop_End"
    assert found["l_shoulder"] == "mixamorig:LeftArm"


RENAMED = {"LeftUpLeg": "Thigh_L", "LeftLeg": "Calf_L", "Hips": "Pelvis_Bone"}


def test_unknown_names_explain_the_mapping(tmp_path: Path) -> None:
    path = tmp_path / "odd.bvh"
    path.write_text(mini_bvh(arms_down(3), names=RENAMED))
    with pytest.raises(MocapError) as info:
        load_mocap(path)
    message = str(info.value)
    assert message.startswith(f"{path}: joint names match no built-in landmark table")
    assert "not found: l_hip, l_knee" in message and "Thigh_L, Calf_L" in message
    template = message[message.index("[landmarks]") :]
    table = tomllib.loads(template)["landmarks"]
    assert tuple(table) == LANDMARKS
    assert table["l_hip"] == "" and table["r_hip"] == "RightUpLeg"


def test_mapping_file_and_dict(tmp_path: Path) -> None:
    path = tmp_path / "odd.bvh"
    path.write_text(mini_bvh(arms_down(3), names=RENAMED))
    toml = tmp_path / "odd.toml"
    toml.write_text('[landmarks]\nl_hip = "Thigh_L"\nl_knee = ["Knee_L", "calf_l"]\n')
    clip = load_mocap(path, mapping=toml)
    assert clip.landmark_map["l_hip"] == "Thigh_L" and clip.landmark_map["l_knee"] == "Calf_L"
    assert "pelvis" not in clip.landmark_map  # "Pelvis_Bone" is in no table: hip midpoint
    marks = clip.landmarks()
    assert marks["pelvis"].tolist() == ((marks["l_hip"] + marks["r_hip"]) / 2).tolist()
    same = load_mocap(path, mapping={"l_hip": "Thigh_L", "l_knee": "Calf_L"})
    assert same.landmarks()["l_knee"].tolist() == clip.landmarks()["l_knee"].tolist()
    # the mapping overrides a table that matches
    plain = tmp_path / "plain.bvh"
    plain.write_text(mini_bvh(arms_down(3)))
    over = load_mocap(plain, mapping={"head": "Head"})
    assert over.landmark_map["head"] == "Head"


def test_bad_mappings(tmp_path: Path) -> None:
    path = tmp_path / "plain.bvh"
    path.write_text(mini_bvh(arms_down(3)))
    cases = {
        "[landmarks]\nl_foot = 'LeftFoot'\n": r"map.toml: unknown landmark 'l_foot'",
        "[landmarks]\nl_hip = 'Nope'\n": r"landmarks.l_hip = 'Nope' is not a joint of .*plain.bvh",
        "[landmarks]\nl_hip = 3\n": r"landmarks.l_hip must be a joint name",
        "pelvis = 'Hips'\n": r"expected a \[landmarks\] table",
        "[landmarks\n": r"map.toml: invalid TOML",
    }
    toml = tmp_path / "map.toml"
    for text, pattern in cases.items():
        toml.write_text(text)
        with pytest.raises(MocapError, match=pattern):
            load_mocap(path, mapping=toml)
    with pytest.raises(MocapError, match="cannot read the mapping"):
        load_mocap(path, mapping=tmp_path / "absent.toml")


def test_template_lists_every_landmark() -> None:
    table = tomllib.loads(mapping_template({"l_hip": "Thigh_L"}))["landmarks"]
    assert tuple(table) == LANDMARKS and table["l_hip"] == "Thigh_L" and table["head"] == ""


def test_skeleton_tree_of_all_and_of_some_landmarks() -> None:
    from motionkit.mocap.naming import skeleton

    names, parents = skeleton(LANDMARKS)
    assert names == LANDMARKS and parents.count(-1) == 1 and parents[0] == -1
    bone = {names[i]: names[p] for i, p in enumerate(parents) if p >= 0}
    assert bone["l_toe"] == "l_ankle" and bone["r_hip"] == "pelvis" and bone["r_wrist"] == "r_elbow"
    assert bone["l_shoulder"] == "neck" and bone["neck"] == "chest"
    # without pelvis and chest: hips and spine become roots; the neck hangs from the spine
    names, parents = skeleton(["neck", "l_knee", "spine", "l_hip", "r_hip", "unknown"])
    assert names == ("l_hip", "l_knee", "r_hip", "spine", "neck")
    assert parents == (-1, 0, -1, -1, 3)
