"""Hostile robot descriptions through `motionkit robot export`: each is refused with one line
naming the file and the problem, and the earlier export of the good robot (same name, same
output file) stays as it was."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from conftest import TOY_SPEC, toy_biped_urdf
from hostile_support import no_hang, refused, snapshot

from motionkit.cli import main

GOOD = toy_biped_urdf()
AXIS = '<axis xyz="0 1 0"/>'
LIMIT = 'lower="-1.5" upper="1.5"'
EXTRA = (
    '<link name="a"/><link name="b"/>'
    '<joint name="ab" type="fixed"><parent link="a"/><child link="b"/></joint>'
    '<joint name="ba" type="fixed"><parent link="b"/><child link="a"/></joint>'
)
LOOP = (
    '<joint name="foot_to_pelvis" type="fixed"><parent link="l_foot"/><child link="pelvis"/>'
    "</joint>"
)
SECOND_PARENT = (
    '<joint name="shin_again" type="fixed"><parent link="pelvis"/><child link="l_shin"/></joint>'
)

# (URDF text or bytes, spec text, patterns the error line must match)
CASES: dict[str, tuple[str | bytes, str, tuple[str, ...]]] = {
    "zero axis": (
        GOOD.replace(AXIS, '<axis xyz="0 0 0"/>', 1),
        TOY_SPEC,
        (r"joint 'shoulder': axis xyz '0 0 0' has zero length",),
    ),
    "nan axis": (
        GOOD.replace(AXIS, '<axis xyz="nan 1 0"/>', 1),
        TOY_SPEC,
        (r"joint 'shoulder' axis xyz: expected 3 finite numbers, got 'nan 1 0'",),
    ),
    "joint cycle": (
        GOOD.replace("</robot>", LOOP + "</robot>"),
        TOY_SPEC,
        (r"no root link: the joints form a cycle l_thigh -> l_shin -> l_foot -> pelvis -> l_thi",),
    ),
    "detached cycle": (
        GOOD.replace("</robot>", EXTRA + "</robot>"),
        TOY_SPEC,
        (r"the joints form a cycle (a -> b -> a|b -> a -> b); a URDF must be a tree",),
    ),
    "link with two parents": (
        GOOD.replace("</robot>", SECOND_PARENT + "</robot>"),
        TOY_SPEC,
        (r"link 'l_shin' is the child of two joints, 'l_knee' and 'shin_again'",),
    ),
    "non-numeric limit": (
        GOOD.replace(LIMIT, 'lower="low" upper="1.5"', 1),
        TOY_SPEC,
        (r"joint 'shoulder' limit lower: expected a finite number, got 'low'",),
    ),
    "nan limit": (
        GOOD.replace(LIMIT, 'lower="-1.5" upper="NaN"', 1),
        TOY_SPEC,
        (r"joint 'shoulder' limit upper: expected a finite number, got 'NaN'",),
    ),
    "origin of two numbers": (
        GOOD.replace('xyz="0 0.15 0.1"', 'xyz="0 0.15"', 1),
        TOY_SPEC,
        (r"joint 'shoulder' origin xyz: expected 3 finite numbers, got '0 0.15'",),
    ),
    "unknown joint type": (
        GOOD.replace('name="elbow_joint" type="revolute"', 'name="elbow_joint" type="hinge"'),
        TOY_SPEC,
        (r"joint 'elbow_joint': type 'hinge' is not one of revolute, continuous, prismatic, fix",),
    ),
    "repeated link": (
        GOOD.replace("</robot>", '<link name="arm"/></robot>'),
        TOY_SPEC,
        (r"link 'arm': a second link of that name",),
    ),
    "a string where a list belongs": (
        GOOD,
        TOY_SPEC.replace('elbows = ["elbow"]', 'elbows = "elbow"'),
        (r"toy\.toml: 'elbows' should be \[str, \.\.\.\], got 'elbow'",),
    ),
    "missing frame": (
        GOOD,
        TOY_SPEC.replace('sole = "l_sole"', 'sole = "l_sol"'),
        (r"toy\.urdf: no link named l_sol \(did you mean l_sole\?\) \(needed for the frames",),
    ),
    "non-UTF-8 bytes": (
        GOOD.replace('<link name="arm">', '<link name="armé">').encode("latin-1"),
        TOY_SPEC,
        (r"toy\.urdf line 1: cannot read URDF: byte 0xe9 is not UTF-8",),
    ),
    "empty file": ("", TOY_SPEC, (r"toy\.urdf: cannot read URDF: the file is empty",)),
    "not XML": (
        b"\x89PNG\r\n\x1a\n" + bytes(64),
        TOY_SPEC,
        (r"toy\.urdf line 3: cannot read URDF: a NUL byte",),
    ),
}


@pytest.fixture(scope="module")
def exported(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder holding the good toy robot's URDF export."""
    folder = tmp_path_factory.mktemp("good")
    (folder / "toy.urdf").write_text(GOOD)
    (folder / "toy.toml").write_text(TOY_SPEC)
    out = folder / "out"
    argv = ["robot", "export", "--format", "urdf", "--out", str(out)]
    assert (
        main([*argv, "--urdf", str(folder / "toy.urdf"), "--spec", str(folder / "toy.toml")]) == 0
    )
    assert list(snapshot(out)) == ["toy.urdf"]
    return out


def _export(urdf: Path, spec: Path, out: Path) -> list[str]:
    return ["robot", "export", "--format", "urdf", "--out", str(out), "--urdf", str(urdf),
            "--spec", str(spec)]  # fmt: skip


@pytest.mark.parametrize("case", CASES)
def test_hostile_robot(
    case: str, exported: Path, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    urdf_content, spec_text, patterns = CASES[case]
    urdf, spec = tmp_path / "toy.urdf", tmp_path / "toy.toml"
    if isinstance(urdf_content, bytes):
        urdf.write_bytes(urdf_content)
    else:
        urdf.write_text(urdf_content)
    spec.write_text(spec_text)
    before = snapshot(exported)
    line = refused(_export(urdf, spec, exported), capsys, 2, r"^motionkit: error: ", *patterns)
    assert str(tmp_path) in line  # names the file
    assert snapshot(exported) == before


@pytest.mark.parametrize("device", ["/dev/zero", "fifo"])
def test_urdf_that_is_not_a_file(
    device: str, exported: Path, tmp_path: Path, capsys: pytest.CaptureFixture
) -> None:
    spec = tmp_path / "toy.toml"
    spec.write_text(TOY_SPEC)
    urdf = Path(device)
    if device == "fifo":
        if not hasattr(os, "mkfifo"):
            pytest.skip("no FIFOs on this system")
        urdf = tmp_path / "toy.urdf"
        os.mkfifo(urdf)
    elif not urdf.exists():
        pytest.skip(f"no {device}")
    before = snapshot(exported)
    kind = "a FIFO" if device == "fifo" else "a character device"
    with no_hang():
        refused(_export(urdf, spec, exported), capsys, 2, rf"{urdf}: cannot read URDF: {kind}")
    assert snapshot(exported) == before
