"""Mocap readers (BVH, ASF/AMC), human skeleton kinematics, CMU clip download.

    clip = load_mocap("02_01.bvh")          # metres, Z-up, leading T-pose dropped
    clip.landmarks()["l_knee"]              # (T, 3) world positions

Conventions: metres, Z-up (files are Y-up: x' = x, y' = -z, z' = y), rotations as 3x3 matrices.
"""

from __future__ import annotations

from pathlib import Path

from motionkit.core.errors import MocapError
from motionkit.mocap.naming import LANDMARKS, MappingSource, mapping_template
from motionkit.mocap.skeleton import UNITS, MocapClip, Skeleton

__all__ = [
    "LANDMARKS",
    "UNITS",
    "MocapClip",
    "MocapError",
    "Skeleton",
    "load_mocap",
    "mapping_template",
]


def load_mocap(
    path: str | Path,
    *,
    asf: str | Path | None = None,
    mapping: MappingSource = None,
    units: str | float | None = None,
    rate: float | None = None,
    keep_tpose: bool = False,
) -> MocapClip:
    """Read a .bvh, or an .amc with its .asf skeleton, as a MocapClip in metres, Z-up.

    The file's Y-up axes become Z-up (x' = x, y' = -z, z' = y); the skeleton's landmarks are
    resolved from the built-in joint name tables and `mapping` when the file is read.

    Args:
        path: the .bvh or .amc file.
        asf: the skeleton of an .amc; default `<subject>.asf` beside it (02_01.amc -> 02.asf),
            else the only .asf in its folder. Refused for a .bvh.
        mapping: landmark -> joint name overrides: a TOML file (`[landmarks] l_knee =
            "LeftLeg"`) or a dict (a name or a list of candidate names per landmark); needed
            only when the names match no built-in table.
        units: file unit, one of UNITS ("m", "cm", "mm", "inch", "cmu") or metres per unit.
            Default: BVH auto-detected from the rest-pose leg length (closest to 0.85 m); ASF
            from its `:units length` (1 unit = 0.0254 / length m).
        rate: frames per second [Hz]; default BVH `Frame Time`, AMC 120 Hz (CMU).
        keep_tpose: keep a leading calibration T-pose frame (CMU BVH conversions have one).

    Returns:
        The clip: the skeleton (joint offsets (J, 3) [m]), the root translation (T, 3) [m],
        local joint rotations (T, J, 3, 3), the frame rate [Hz] and the landmark -> joint map.

    Raises:
        MocapError: a missing file, an unknown suffix, `asf` with a .bvh, no .asf found for an
            .amc, a file that does not parse, joint names that no table or `mapping` resolves,
            or a take whose size or rate is implausible.
    """
    path = Path(path)
    if not path.is_file():
        raise MocapError(f"{path}: no such file")
    suffix = path.suffix.lower()
    if suffix == ".bvh":
        from motionkit.mocap.bvh import read_bvh

        if asf is not None:
            raise MocapError(f"{path}: asf= applies to .amc files only")
        return read_bvh(path, mapping=mapping, units=units, rate=rate, keep_tpose=keep_tpose)
    if suffix == ".amc":
        from motionkit.mocap.asf_amc import find_asf, read_asf_amc

        skeleton = Path(asf) if asf is not None else find_asf(path)
        return read_asf_amc(
            skeleton, path, mapping=mapping, units=units, rate=rate, keep_tpose=keep_tpose
        )
    raise MocapError(f"{path}: unknown mocap format '{path.suffix}' (expected .bvh or .amc)")
