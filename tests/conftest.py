"""Shared fixtures: a private cache, the ../shared reference (skips if absent), a toy robot."""

import os
import sys
from pathlib import Path

import pytest

SHARED = Path(__file__).resolve().parents[1] / ".." / "shared"
# test helpers that build mocap files (tests/mocap/mocap_synth.py) serve other stages' tests too
sys.path.insert(0, str(Path(__file__).resolve().parent / "mocap"))


MAX_WORKERS = 4  # each worker compiles MJX and the trajopt problem once: memory, not cores


def pytest_xdist_auto_num_workers(config: pytest.Config) -> int:
    """`-n auto`: one worker per core this process may use, at most MAX_WORKERS."""
    usable = os.sched_getaffinity(0) if hasattr(os, "sched_getaffinity") else None
    cores = len(usable) if usable else os.cpu_count() or 1
    return max(1, min(cores, MAX_WORKERS))


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Modules with the most slow tests first, each in its own order: the workers take the
    long modules early instead of one of them finishing the run alone."""
    slow: dict[str, int] = {}
    for item in items:
        module = item.nodeid.split("::")[0]
        slow[module] = slow.get(module, 0) + (item.get_closest_marker("slow") is not None)
    items.sort(key=lambda item: -slow[item.nodeid.split("::")[0]])


@pytest.fixture(autouse=True, scope="session")
def _private_cache(tmp_path_factory: pytest.TempPathFactory) -> None:
    """A motionkit cache of this process's own; one XLA compile cache for the whole run (every
    worker and the commands they start): MJX compiles the same small environment for minutes
    in many tests, and a program compiled once is loaded by the others."""
    base = tmp_path_factory.getbasetemp()
    shared = base.parent if os.environ.get("PYTEST_XDIST_WORKER") else base
    (shared / "xla").mkdir(exist_ok=True)
    mp = pytest.MonkeyPatch()
    mp.setenv("MOTIONKIT_CACHE", str(tmp_path_factory.mktemp("motionkit-cache")))
    mp.setenv("JAX_COMPILATION_CACHE_DIR", str(shared / "xla"))
    yield
    mp.undo()


@pytest.fixture(scope="session")
def reference_urdf() -> Path:
    """The public iRonCub-Mk1_1 URDF from ../shared/reference, or skip."""
    path = SHARED / "reference" / "ironcub-mk1_1" / "model.urdf"
    if not path.exists():
        pytest.skip("../shared/reference is not present")
    return path


def _link(name: str, mass: float | None = None, size: float = 0.1) -> str:
    if mass is None:
        return f'<link name="{name}"/>'
    inertia = mass * size * size / 6  # uniform cube of side `size`
    return (
        f'<link name="{name}"><inertial><origin xyz="0 0 0"/><mass value="{mass}"/>'
        f'<inertia ixx="{inertia}" iyy="{inertia}" izz="{inertia}" ixy="0" ixz="0" iyz="0"/>'
        "</inertial></link>"
    )


def _joint(
    name: str, parent: str, child: str, xyz: str, kind: str = "revolute", rpy: str = "0 0 0"
) -> str:
    motion = '<axis xyz="0 1 0"/><limit lower="-1.5" upper="1.5" velocity="10" effort="50"/>'
    return (
        f'<joint name="{name}" type="{kind}"><origin xyz="{xyz}" rpy="{rpy}"/>'
        f'<parent link="{parent}"/><child link="{child}"/>'
        f"{motion if kind == 'revolute' else ''}</joint>"
    )


def toy_biped_urdf(elbow_mass: float = 0.5) -> str:
    """A small jet-powered biped (11 kg): pelvis, two 3-joint legs, one elbow joint, two jets."""
    parts = [_link("pelvis", 4.0, 0.2), _link("arm", 0.5), _link("elbow", elbow_mass)]
    parts.append(_joint("shoulder", "pelvis", "arm", "0 0.15 0.1"))
    parts.append(_joint("elbow_joint", "arm", "elbow", "0 0 -0.2"))
    parts.append(_link("jet_a", 1.0))
    parts.append(
        _joint("jet_a_fixed", "pelvis", "jet_a", "0 0.1 0", "fixed", "3.14159265358979 0 0")
    )
    parts.append(_link("jet_b", 1.0))
    parts.append(
        _joint("jet_b_fixed", "pelvis", "jet_b", "0 -0.1 0", "fixed", "3.14159265358979 0 0")
    )
    for side, y in (("l", 0.1), ("r", -0.1)):
        parts += [
            _link(f"{side}_thigh", 1.0),
            _link(f"{side}_shin", 0.5),
            _link(f"{side}_foot", 0.5),
        ]
        parts.append(_joint(f"{side}_hip", "pelvis", f"{side}_thigh", f"0 {y} -0.1"))
        parts.append(_joint(f"{side}_knee", f"{side}_thigh", f"{side}_shin", "0 0 -0.3"))
        parts.append(_joint(f"{side}_ankle", f"{side}_shin", f"{side}_foot", "0 0 -0.3"))
        sole = _joint(f"{side}_sole_fixed", f"{side}_foot", f"{side}_sole", "0 0 -0.05", "fixed")
        parts += [_link(f"{side}_sole"), sole]
        for k, (cx, cy) in enumerate(((0.1, 0.04), (0.1, -0.04), (-0.05, -0.04), (-0.05, 0.04))):
            corner = f"{side}_sole_{k + 1}"
            parts += [
                _link(corner),
                _joint(f"{corner}_fixed", f"{side}_sole", corner, f"{cx} {cy} 0", "fixed"),
            ]
    return '<robot name="toy">' + "".join(parts) + "</robot>"


TOY_SPEC = """
name = "toy"
root = "pelvis"
forward = [1.0, 0.0, 0.0]
joints = ["shoulder", "l_hip", "l_knee", "l_ankle", "r_hip", "r_knee", "r_ankle"]
elbows = ["elbow"]
[feet.left]
sole = "l_sole"
corners = ["l_sole_1", "l_sole_2", "l_sole_3", "l_sole_4"]
[feet.right]
sole = "r_sole"
corners = ["r_sole_1", "r_sole_2", "r_sole_3", "r_sole_4"]
[[jets]]
name = "a"
frame = "jet_a"
t_max = 100.0
[[jets]]
name = "b"
frame = "jet_b"
t_max = 100.0
"""


@pytest.fixture
def toy_robot_files(tmp_path: Path) -> tuple[Path, Path]:
    """A valid user robot: URDF and spec TOML written to a temporary folder."""
    urdf, spec = tmp_path / "toy.urdf", tmp_path / "toy.toml"
    urdf.write_text(toy_biped_urdf())
    spec.write_text(TOY_SPEC)
    return urdf, spec


@pytest.fixture(scope="session")
def toy_robot(tmp_path_factory: pytest.TempPathFactory):  # -> motionkit.robot.Robot
    """The toy biped loaded as a Robot (joints along y; sole 0.65 m below the hip)."""
    from motionkit.robot import load_robot

    folder = tmp_path_factory.mktemp("toy")
    (folder / "toy.urdf").write_text(toy_biped_urdf())
    (folder / "toy.toml").write_text(TOY_SPEC)
    return load_robot(folder / "toy.urdf", folder / "toy.toml")
