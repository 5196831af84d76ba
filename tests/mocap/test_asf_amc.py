"""ASF/AMC reader: the Acclaim formula by hand, units, CRLF and comments, ASF discovery, errors."""

import shutil
from pathlib import Path

import numpy as np
import pytest
from mocap_synth import (
    amc_in_radians,
    amc_text,
    synth_body,
    synth_files,
    synth_motion,
    write_asf,
)

from motionkit.mocap import MocapError, load_mocap
from motionkit.mocap.asf_amc import _dof_motion, angle_unit_hint, find_asf, read_amc, read_asf
from motionkit.mocap.skeleton import axis_rotation
from motionkit.recipes import sample_mocap


@pytest.fixture(scope="module")
def synth(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    return synth_files(tmp_path_factory.mktemp("synth"))


def test_acclaim_rotation_by_hand() -> None:
    """axis 0 0 90 (C = Rz(90) maps the bone's x to global y): rx = 90 about the bone's x is a
    quarter turn about global (Y-up) y, which is Z-up z."""
    values = np.array([[90.0]])
    rot, shift, grow = _dof_motion(("rx",), values, np.radians([0, 0, 90]), "xyz", True)
    np.testing.assert_allclose(rot[0], axis_rotation("z", np.pi / 2), atol=1e-12)
    # dof order: "rz rx" applies z first, so M = Rx Rz; Y-up -> Z-up maps x->x, z->-y
    values = np.array([[90.0, 90.0]])
    rot, _, _ = _dof_motion(("rz", "rx"), values, np.zeros(3), "xyz", True)
    expected = axis_rotation("x", np.pi / 2) @ axis_rotation("y", -np.pi / 2)
    np.testing.assert_allclose(rot[0], expected, atol=1e-12)
    # translations are in the bone's axis frame: tx with C = Rz(90) moves along Y-up y
    _, shift, grow = _dof_motion(
        ("tx", "l"), np.array([[2.0, 0.5]]), np.radians([0, 0, 90]), "xyz", True
    )
    np.testing.assert_allclose(shift[0], [0, 2, 0], atol=1e-12)
    assert grow[0] == 0.5


def test_reads_synthetic_asf_amc(synth: dict[str, Path]) -> None:
    clip = load_mocap(synth["amc"])
    assert clip.name == "07_03" and clip.format == "asf/amc" and clip.frames == 6
    assert clip.rate == 120.0 and clip.units_scale == pytest.approx(0.0254 / 0.45)
    names = clip.skeleton.names
    assert names[0] == "root" and "ltoes_end" in names and "head_end" in names
    assert clip.landmark_map["l_knee"] == "ltibia" and clip.landmark_map["head"] == "head_end"
    # rest: the knee sits femur.length along femur.direction from the hip
    rest = clip.skeleton.offsets[names.index("ltibia")]
    direction = np.array([0.34, 0.0, -0.94]) / np.linalg.norm([0.34, 0.94])  # Z-up
    np.testing.assert_allclose(rest, direction * 7.3 * 0.0254 / 0.45, atol=1e-9)
    # root translation: AMC TX TY TZ, Y-up CMU units -> Z-up metres
    first = np.array([2.0, 16.0, 3.0]) * 0.0254 / 0.45
    np.testing.assert_allclose(clip.root_translation[0], [first[0], -first[2], first[1]])
    assert load_mocap(synth["amc"], rate=60.0).rate == 60.0


def test_crlf_comments_radians_and_explicit_asf(tmp_path: Path, synth: dict[str, Path]) -> None:
    reference = load_mocap(synth["amc"])
    bones = synth_body()
    values = synth_motion(bones)
    asf = write_asf(tmp_path / "skeleton.asf", bones, angle="rad")
    text = amc_text(bones, values, crlf=True)
    lines = text.split("\r\n")
    lines.insert(10, "# a comment between bone lines")  # forces the line-by-line path
    amc = tmp_path / "take.amc"
    amc.write_bytes("\r\n".join(lines).encode())
    clip = load_mocap(amc, asf=asf)
    assert clip.frames == 6
    for key, value in reference.landmarks().items():
        np.testing.assert_allclose(clip.landmarks()[key], value, atol=1e-9)
    fast = tmp_path / "fast.amc"
    fast.write_bytes(text.encode())
    np.testing.assert_allclose(load_mocap(fast, asf=asf).rotations, clip.rotations, atol=1e-12)


def test_length_dof_stretches_the_bone(tmp_path: Path) -> None:
    bones = synth_body()
    values = synth_motion(bones)
    lines = write_asf(tmp_path / "07.asf", bones).read_text().splitlines()
    start = lines.index("     name lradius")
    dof = next(k for k in range(start, len(lines)) if lines[k].strip().startswith("dof"))
    lines[dof] = "    dof rx l"
    (tmp_path / "07.asf").write_text("\n".join(lines) + "\n")
    stretch = np.linspace(0.0, 1.0, 6)
    values["lradius"] = np.hstack([values["lradius"], stretch[:, None]])
    amc = tmp_path / "07_01.amc"
    amc.write_text(amc_text(bones, values))
    clip = load_mocap(amc)
    assert clip.translations is not None
    marks = clip.landmarks()
    forearm = np.linalg.norm(marks["l_wrist"] - marks["l_elbow"], axis=1)
    np.testing.assert_allclose(forearm, (3.4 + stretch) * 0.0254 / 0.45, atol=1e-9)


def test_find_asf(tmp_path: Path, synth: dict[str, Path]) -> None:
    amc = tmp_path / "02_01.amc"
    shutil.copy(synth["amc"], amc)
    for name in ("01.asf", "02.asf", "03.asf"):
        shutil.copy(synth["asf"], tmp_path / name)
    assert find_asf(amc) == tmp_path / "02.asf"
    prefixed = tmp_path / "cmu" / "cmu_05_01_walk.amc"
    prefixed.parent.mkdir()
    shutil.copy(synth["amc"], prefixed)
    shutil.copy(synth["asf"], prefixed.parent / "cmu_05.asf")
    shutil.copy(synth["asf"], prefixed.parent / "cmu_06.asf")
    assert find_asf(prefixed) == prefixed.parent / "cmu_05.asf"
    only = tmp_path / "only" / "walk.amc"
    only.parent.mkdir()
    shutil.copy(synth["amc"], only)
    shutil.copy(synth["asf"], only.parent / "whatever.asf")
    assert find_asf(only) == only.parent / "whatever.asf"
    (only.parent / "whatever.asf").unlink()
    with pytest.raises(MocapError, match=r"walk.amc: no ASF skeleton found .*pass asf="):
        load_mocap(only)


# --- malformed files ------------------------------------------------------------------------


@pytest.fixture
def take(tmp_path: Path, synth: dict[str, Path]) -> tuple[Path, list[str]]:
    """A copy of the synthetic take beside its ASF, and its lines."""
    shutil.copy(synth["asf"], tmp_path / "07.asf")
    return tmp_path / "07_09.amc", synth["amc"].read_text().splitlines()


def _fails(amc: Path, lines: list[str], pattern: str) -> None:
    amc.write_text("\n".join(lines) + "\n")
    with pytest.raises(MocapError, match=pattern) as info:
        load_mocap(amc)
    assert "\n" not in str(info.value)


def test_frame_missing_a_bone(take) -> None:
    amc, lines = take
    header = lines.index("2")  # frame 2's number line
    femur = next(n for n in range(header, len(lines)) if lines[n].startswith("lfemur "))
    _fails(
        amc,
        lines[:femur] + lines[femur + 1 :],
        rf"frame 2 \(line {header + 1}\): bone 'lfemur' missing",
    )
    last = lines.index("6")
    _fails(amc, lines[:-1], rf"frame 6 \(line {last + 1}\): bone '\w+' missing")


def test_bone_not_in_asf_and_bad_values(take) -> None:
    amc, lines = take
    n = lines.index("3") + 2
    bad = [*lines]
    bad[n] = "ltail 1 2 3"
    _fails(amc, bad, rf"line {n + 1}: bone 'ltail' is not in the ASF")
    bad = [*lines]
    name, *values = bad[n].split()
    bad[n] = " ".join([name, *values[:-1]])
    _fails(amc, bad, rf"line {n + 1}: bone '{name}' has {len(values) - 1} values, expected")
    bad = [*lines]
    bad[n] = f"{name} {' '.join(['x1'] * len(values))}"
    _fails(amc, bad, rf"line {n + 1}: bone '{name}': unreadable number")
    bad = [*lines]
    bad[3:3] = ["root 1 2 3 4 5 6"]
    _fails(amc, bad, r"line 4: expected a frame number")


def test_bad_asf(tmp_path: Path, synth: dict[str, Path]) -> None:
    text = synth["asf"].read_text()
    asf = tmp_path / "07.asf"
    amc = tmp_path / "07_01.amc"
    shutil.copy(synth["amc"], amc)

    def fails(content: str, pattern: str) -> None:
        asf.write_text(content)
        with pytest.raises(MocapError, match=pattern):
            load_mocap(amc)

    lines = text.splitlines()
    n = next(i for i, line in enumerate(lines) if line.strip() == "lfemur ltibia")
    fails(
        text.replace("lfemur ltibia", "lfemur lshin"),
        rf"07.asf line {n + 1}: .*unknown bone 'lshin'",
    )
    n = next(i for i, line in enumerate(lines) if "direction" in line)
    fails(text.replace(lines[n], "     direction 1 two 3", 1), rf"line {n + 1}: expected 3 numbers")
    fails(text.replace("dof rx ry rz", "dof rx ry rw", 1), r"bone 'lfemur' dof 'rx ry rw'")
    fails(text.replace("axis 0 0 20  XYZ", "axis 0 0 20  XYW", 1), r"axis order 'XYW'")
    fails(text.replace("    lfemur ltibia\n", ""), r"not reachable from root.*ltibia")
    fails(":name nothing\n", r"no :bonedata bones")


# --- angles in the other unit than the files declare -------------------------------------------


@pytest.fixture(scope="module")
def sample_11() -> tuple[Path, Path]:
    """The offline sample's 11_01.amc (degrees) and its 11.asf."""
    return sample_mocap() / "11_01.amc", sample_mocap() / "11.asf"


def test_the_sample_angles_by_hand(sample_11: tuple[Path, Path]) -> None:
    """What the messages below quote: 11_01's largest joint value is 117.494 degrees (2.051
    rad), 82.244 (1.435 rad) in its first second; its root moves 3.1 m over the floor (a
    diagonal of the TX and TZ extents in units of 0.0254 / 0.45 m), 0.17 m in that second."""
    amc, asf = sample_11
    skeleton = read_asf(asf)
    _, values, degrees = read_amc(amc, skeleton)
    joints = [a for name, a in values.items() if name != "root"]  # CMU bones: rotations only
    assert degrees and max(np.abs(a).max() for a in joints) == pytest.approx(117.494)
    assert max(np.abs(a[:120]).max() for a in joints) == pytest.approx(82.2437)
    assert np.radians([117.494, 82.2437]) == pytest.approx([2.0507, 1.4354], abs=1e-4)
    root = values["root"][:, [0, 2]] * 0.0254 / 0.45
    assert np.linalg.norm(np.ptp(root, axis=0)) == pytest.approx(3.1475, abs=1e-4)
    assert np.linalg.norm(np.ptp(root[:120], axis=0)) == pytest.approx(0.1706, abs=1e-4)
    assert angle_unit_hint(amc, asf) == ""


def test_radians_under_a_degrees_header_are_refused(
    sample_11: tuple[Path, Path], tmp_path: Path
) -> None:
    """The sample in radians: every value within +-pi, refused by that alone; with its heading
    past pi (2 pi added to the root's RY: the same motion) refused as a body that glides 3.1 m
    without turning a joint 2.1 degrees."""
    amc, asf = sample_11
    shutil.copy(asf, tmp_path / "11.asf")
    plain = amc_in_radians(amc, asf, tmp_path / "11_01.amc")
    within_pi = r"every rotation value lies within \+-pi \(largest 2\.051\)"
    with pytest.raises(MocapError, match=within_pi):
        load_mocap(plain)
    turned = amc_in_radians(amc, asf, tmp_path / "11_02.amc", root_turn=2 * np.pi)
    message = (
        r"11_02\.amc: read in degrees, but no joint turns more than 2\.1 degrees \(every joint "
        r"value within \+-2 pi, largest 2\.051\) while the root travels 3\.1 m: radians, it "
        r"seems; add ':RADIANS' to the AMC header or set 'angle rad' in the ASF's :units$"
    )
    with pytest.raises(MocapError, match=message):
        load_mocap(turned)


def test_angle_unit_hints(sample_11: tuple[Path, Path], tmp_path: Path) -> None:
    """The sample's first second in radians, heading past pi: it stands (the root moves
    0.17 m), so it reads, and the hint names the mix-up; the synthetic take's degrees under a
    ':RADIANS' header reach its largest joint value (a knee at 10 + 50 sin^2 (4 t) degrees)."""
    amc, asf = sample_11
    standing = amc_in_radians(amc, asf, tmp_path / "11_01.amc", root_turn=2 * np.pi, frames=120)
    assert load_mocap(standing, asf=asf).frames == 120
    assert angle_unit_hint(standing, asf) == (
        "11_01.amc's angles look like radians read as degrees: its joint angles stay within "
        "+-2 pi (largest 1.435), so no joint turns more than 1.4 degrees; add ':RADIANS' to "
        "the AMC header or set 'angle rad' in 11.asf's :units"
    )
    files = synth_files(tmp_path)
    values = synth_motion(synth_body())
    largest = max(np.abs(v).max() for name, v in values.items() if name != "root")
    assert largest == pytest.approx(10 + 50 * np.sin(4 * 0.4) ** 2)
    files["amc"].write_text(files["amc"].read_text().replace(":DEGREES", ":RADIANS"))
    assert angle_unit_hint(files["amc"], files["asf"]) == (
        f"07_03.amc's angles look like degrees read as radians: joint angles reach "
        f"{largest:.1f}, beyond a full turn; remove ':RADIANS' from the AMC header or set "
        "'angle deg' in 07.asf's :units"
    )
    assert angle_unit_hint(tmp_path / "missing.amc", files["asf"]) == ""
