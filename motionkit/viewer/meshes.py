"""The robot's visual shapes as triangle meshes in their link frames, cached per robot model.

URDF meshes (STL, OBJ, DAE... through trimesh) and primitives (box, cylinder, sphere). Loading
the iCub meshes takes about 0.7 s; the triangles are cached in the robot's cache folder (an .npz
keyed by the model hash) so that later starts read them in a few milliseconds.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from motionkit.robot import Robot
from motionkit.robot.model import cache_dir
from motionkit.robot.urdf import Shape

CACHE_NAME = "viewer_meshes.npz"
GREY = (0.7, 0.7, 0.7, 1.0)


@dataclass(frozen=True)
class LinkMesh:
    link: str
    vertices: np.ndarray  # (V, 3) float32, in the link frame
    faces: np.ndarray  # (F, 3) uint32
    color: tuple[int, int, int]  # RGB 0-255


def robot_meshes(robot: Robot, use_cache: bool = True) -> tuple[list[LinkMesh], list[str]]:
    """Every visual shape of the robot, and a note for each one that could not be loaded."""
    path = cache_dir() / "robots" / f"{robot.name}-{robot.model_hash}" / CACHE_NAME
    if use_cache and path.is_file():
        try:
            return _load_cache(path), []
        except (OSError, ValueError, KeyError):
            pass  # rebuilt below
    meshes, problems = [], []
    base = Path(robot.model.source).parent if Path(robot.model.source).is_file() else None
    for link in robot.model.subtree(robot.model.root):
        for shape in robot.model.links[link].visuals:
            try:
                vertices, faces = _triangles(shape, base)
            except (OSError, ValueError) as exc:
                problems.append(f"{link}: {exc}")
                continue
            rgba = shape.rgba or GREY
            color = tuple(round(255 * c) for c in rgba[:3])
            meshes.append(LinkMesh(link, vertices, faces, color))  # type: ignore[arg-type]
    if use_cache and not problems:
        _save_cache(path, meshes)
    return meshes, problems


def _triangles(shape: Shape, base: Path | None) -> tuple[np.ndarray, np.ndarray]:
    import trimesh

    if not len(shape.geometry):
        raise ValueError("empty <geometry>")
    element = shape.geometry[0]
    kind = element.tag

    def number(key: str) -> float:
        return float(element.get(key, "0"))

    def numbers(key: str, default: str) -> list[float]:
        return [float(v) for v in element.get(key, default).split()]

    if kind == "mesh":
        mesh = trimesh.load(_resolve(element.get("filename", ""), base), force="mesh")
        mesh.apply_scale(np.array(numbers("scale", "1 1 1")))
    elif kind == "box":
        mesh = trimesh.creation.box(extents=numbers("size", "0 0 0"))
    elif kind == "cylinder":
        mesh = trimesh.creation.cylinder(radius=number("radius"), height=number("length"))
    elif kind == "sphere":
        mesh = trimesh.creation.icosphere(radius=number("radius"))
    else:
        raise ValueError(f"unsupported visual geometry <{kind}>")
    mesh.apply_transform(shape.origin)
    return np.asarray(mesh.vertices, np.float32), np.asarray(mesh.faces, np.uint32)


def _resolve(filename: str, base: Path | None) -> Path:
    """A mesh path: absolute, relative to the URDF, or package://name/... under a ROS package
    path or this environment's share folder."""
    if filename.startswith("file://"):
        filename = filename[len("file://") :]
    if filename.startswith("package://"):
        package, _, rest = filename[len("package://") :].partition("/")
        roots = [Path(p) for p in os.environ.get("ROS_PACKAGE_PATH", "").split(os.pathsep) if p]
        roots += [Path(sys.prefix) / "share"]
        for root in roots:
            for candidate in (root / package / rest, root / rest):
                if candidate.is_file():
                    return candidate
        raise OSError(f"mesh {filename} not found under ROS_PACKAGE_PATH or {sys.prefix}/share")
    path = Path(filename)
    if not path.is_absolute() and base is not None:
        path = base / path
    if not path.is_file():
        raise OSError(f"mesh file {path} not found")
    return path


def _save_cache(path: Path, meshes: list[LinkMesh]) -> None:
    from motionkit.files.outputs import atomic_output

    arrays: dict[str, np.ndarray] = {"links": np.array([m.link for m in meshes])}
    arrays["colors"] = np.array([m.color for m in meshes], dtype=np.uint8).reshape(-1, 3)
    for i, mesh in enumerate(meshes):
        arrays[f"v{i}"], arrays[f"f{i}"] = mesh.vertices, mesh.faces
    with atomic_output(path) as stream:
        np.savez(stream, **arrays)


def _load_cache(path: Path) -> list[LinkMesh]:
    with np.load(path) as data:
        return [
            LinkMesh(str(link), data[f"v{i}"], data[f"f{i}"], tuple(int(c) for c in color))  # type: ignore[arg-type]
            for i, (link, color) in enumerate(zip(data["links"], data["colors"], strict=True))
        ]
