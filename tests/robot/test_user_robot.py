"""User robots (URDF + spec TOML) through the same code, and the errors for bad descriptions."""

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from conftest import TOY_SPEC, toy_biped_urdf

from motionkit.core.errors import RobotModelError
from motionkit.robot import Robot, RobotSpec, cache_dir, load_robot
from motionkit.robot.urdf import inertia_problem, load_urdf, parse_urdf


def test_toy_robot_builds_and_exports(toy_robot_files: tuple[Path, Path]) -> None:
    robot = load_robot(*toy_robot_files)
    assert robot.name == "toy"
    assert robot.joint_names[0] == "shoulder"
    assert robot.locked_joints == ("elbow_joint",)
    assert robot.total_mass == pytest.approx(4.0 + 0.5 + 0.5 + 2 * 1.0 + 2 * (1.0 + 0.5 + 0.5))
    assert [jet.t_max for jet in robot.spec.jets] == [100.0, 100.0]
    assert "<robot" in robot.urdf_text and "<mujoco" in robot.mjcf_text


def test_toy_robot_in_mujoco(toy_robot_files: tuple[Path, Path]) -> None:
    mujoco = pytest.importorskip("mujoco")
    robot = load_robot(*toy_robot_files)
    model = mujoco.MjModel.from_xml_string(robot.mjcf_text)
    data = mujoco.MjData(model)
    mujoco.mj_resetDataKeyframe(model, data, model.key("stand").id)
    mujoco.mj_forward(model, data)
    # Standing height puts the corners on the floor: 0.1 + 0.3 + 0.3 + 0.05 m below the pelvis.
    assert data.qpos[2] == pytest.approx(0.75)
    # Sole box: corners span 0.15 x 0.08 m.
    np.testing.assert_allclose(model.geom("left_sole").size, [0.075, 0.04, 0.005])
    np.testing.assert_allclose(data.geom("left_sole").xpos, [0.025, 0.1, 0.005], atol=1e-12)
    # The jet frames are flipped (rpy = pi about x): thrust along -z of the frame points up.
    data.ctrl[:] = 0
    data.ctrl[-2:] = 50.0
    mujoco.mj_forward(model, data)
    np.testing.assert_allclose(data.qfrc_actuator[:3], [0, 0, 100.0], atol=1e-9)


def test_round_trip_keeps_kinematics_and_inertia(toy_robot_files: tuple[Path, Path]) -> None:
    robot = load_robot(*toy_robot_files)
    again = parse_urdf(robot.urdf_text, "round trip")
    q = {"l_hip": 0.3, "l_knee": -0.7, "shoulder": 1.1}
    for name, pose in robot.model.link_poses(q).items():
        np.testing.assert_allclose(again.link_poses(q)[name], pose, atol=1e-12)
    assert again.total_mass() == pytest.approx(robot.total_mass, abs=1e-12)
    assert again.to_urdf() == robot.model.to_urdf()  # writing is deterministic


@pytest.mark.parametrize(
    ("mass", "moments", "problem"),
    [
        (1.0, (1.0, 2.0, 2.5), None),
        (0.0, (1.0, 1.0, 1.0), "mass 0.0 is not positive"),
        (1.0, (1.0, -1.0, 1.0), "not all positive"),
        (1.0, (1.0, 1.0, 3.0), "triangle inequality"),  # 1 + 1 < 3
    ],
)
def test_inertia_checks(mass: float, moments: tuple, problem: str | None) -> None:
    result = inertia_problem(mass, np.diag(moments))
    assert result is None if problem is None else problem in result


def _write(tmp_path: Path, urdf: str, spec: str = TOY_SPEC) -> tuple[Path, Path]:
    (tmp_path / "robot.urdf").write_text(urdf)
    (tmp_path / "robot.toml").write_text(spec)
    return tmp_path / "robot.urdf", tmp_path / "robot.toml"


@pytest.mark.parametrize(
    ("urdf", "spec", "message"),
    [
        (toy_biped_urdf(elbow_mass=-1.0), TOY_SPEC, "link 'elbow' has an invalid inertia"),
        (toy_biped_urdf().replace('"l_sole_3"', '"l_sole_x"'), TOY_SPEC, "no link named l_sole_3"),
        (toy_biped_urdf(), TOY_SPEC.replace('"jet_b"', '"jet_c"'), "no link named jet_c"),
        (toy_biped_urdf(), TOY_SPEC.replace('"r_knee"', '"r_knees"'), "no movable joint named"),
        (
            toy_biped_urdf(),
            TOY_SPEC.replace("t_max = 100.0\n", "", 1),
            "[jets[0]]: missing 't_max'",
        ),
        (
            toy_biped_urdf(),
            TOY_SPEC.replace("t_max = 100.0\n", "t_max = 100.0\nlength = 0.2\n", 1),
            "jet 'a' needs both length and radius > 0 m, or neither",
        ),
        (
            toy_biped_urdf(),
            TOY_SPEC.replace("t_max = 100.0\n", 't_max = 100.0\nradius = "wide"\n', 1),
            "[jets[0]]: 'radius' should be float",
        ),
        (toy_biped_urdf(), TOY_SPEC + "[limits]\nvelocity = 3\n", "unknown keys ['velocity']"),
        (toy_biped_urdf(), "name = [", "not valid TOML"),
        (
            toy_biped_urdf(),
            TOY_SPEC + '[simulation]\npd = [{ joints = "*", kp = 1.0 }]\n',
            "[simulation.pd[0]]: missing 'kd'",
        ),
        ("<robot name='x'><link name='a'>", TOY_SPEC, "not valid XML"),
        ("<robot name='x'><link name='a'/><link name='b'/></robot>", TOY_SPEC, "one root link"),
    ],
)
def test_bad_descriptions_are_named(tmp_path: Path, urdf: str, spec: str, message: str) -> None:
    with pytest.raises(RobotModelError, match=message.replace("[", r"\[").replace("]", r"\]")):
        load_robot(*_write(tmp_path, urdf, spec))


def test_public_mk1_1_urdf_is_refused_for_its_elbow_inertia(reference_urdf: Path) -> None:
    model = load_urdf(reference_urdf)
    spec = replace(RobotSpec.builtin("ironcub"), root=model.root)  # its root is base_link
    with pytest.raises(RobotModelError, match=r"link '[lr]_elbow_1' has an invalid inertia"):
        Robot(model, spec, origin="public Mk1_1 URDF")


def test_exports_are_cached_by_content_hash(toy_robot_files: tuple[Path, Path]) -> None:
    robot = load_robot(*toy_robot_files)
    path = robot.mjcf_path()
    assert path.parent == cache_dir() / "robots" / f"toy-{robot.model_hash}"
    assert path.read_text() == robot.mjcf_text
    stamp = path.stat().st_mtime_ns
    assert load_robot(*toy_robot_files).mjcf_path() == path  # same content, same file, untouched
    assert path.stat().st_mtime_ns == stamp
    other_urdf = toy_robot_files[0].with_name("heavier.urdf")
    other_urdf.write_text(toy_biped_urdf(elbow_mass=0.7))
    other = load_robot(other_urdf, toy_robot_files[1])
    assert other.model_hash != robot.model_hash and other.mjcf_path() != path


def test_model_hash_ignores_where_the_meshes_are_installed(tmp_path: Path) -> None:
    """Clips made on one machine load on another: the hash keys on mesh names, not folders."""

    def with_mesh(path: str) -> str:
        visual = f'<visual><geometry><mesh filename="{path}"/></geometry></visual>'
        return toy_biped_urdf().replace('<link name="pelvis">', f'<link name="pelvis">{visual}')

    hashes = []
    for folder, path in (
        ("a", "/opt/venv/share/toy/meshes/pelvis.stl"),
        ("b", "/home/me/.local/share/toy/meshes/pelvis.stl"),
        ("c", "/opt/venv/share/toy/meshes/pelvis_v2.stl"),
    ):
        (tmp_path / folder).mkdir()
        robot = load_robot(*_write(tmp_path / folder, with_mesh(path)))
        assert path in robot.urdf_text  # exports keep the full path
        hashes.append(robot.model_hash)
    assert hashes[0] == hashes[1] != hashes[2]
