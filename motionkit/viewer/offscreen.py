"""The robot drawn by MuJoCo's offscreen renderer: a visual model with the robot's meshes, an
OpenGL context, and the pictures of clip frames (`ClipRenderer`).

The visual model is the robot's MJCF (`Robot.mjcf_text`: joints, link frames, jet sites) with
the browser viewer's meshes (`meshes.robot_meshes`) added as geoms that never collide (the sole
boxes, collisions only, are hidden); a picture sets qpos and runs the kinematics (and places
the lights) only. The camera follows the base from a fixed direction; the floor is a CHECKER m
checker lit by a spotlight that follows the base (its shadows stay with the robot); each jet
draws a flame out of its nozzle along the exhaust, THRUST_LENGTH x T/T_max long like the
browser viewer's arrows; waypoints are blue balls on thin poles down to the floor. A clip's
terrain (`motionkit.viewer.terrain`) is a heightfield geom of its grid, the checker floor moved
below its lowest point when it holds pits.

OpenGL: MUJOCO_GL picks the backend and mujoco reads it when first imported; `default_gl()` sets
it to egl on Linux when it is unset (Mesa's EGL renders without a display, OSMesa often does
not), and `open_gl` makes a context of that backend whatever mujoco picked at import.
"""

from __future__ import annotations

import contextlib
import math
import os
import sys
import warnings
from types import TracebackType
from typing import TYPE_CHECKING, Any

import numpy as np

from motionkit.core.errors import ViewerError
from motionkit.core.extras import require
from motionkit.dataset import Trajectory
from motionkit.robot import Robot
from motionkit.robot.geometry import Array
from motionkit.viewer.meshes import LinkMesh
from motionkit.viewer.posing import quat_to_matrix
from motionkit.viewer.terrain import TerrainPatch, hfield_data

if TYPE_CHECKING:
    import mujoco

    from motionkit.viewer.render import RenderConfig

THRUST_LENGTH = 0.6  # m, flame length at T_max (the browser viewer's thrust arrows)
FLAME_RADIUS = 0.035  # m
FLAME_RGBA = (1.0, 0.45, 0.05, 1.0)
FLAME_EMISSION = 0.7  # glows: bright whatever the light
WAYPOINT_RADIUS = 0.06  # m
WAYPOINT_RGBA = (0.12, 0.43, 0.94, 1.0)
WAYPOINT_EMISSION = 0.4  # seen outside the spotlight too
POLE_RADIUS = 0.006  # m, of the line from a waypoint down to the floor
CHECKER = 0.5  # m, side of a floor square
ROBOT_GROUP = 1  # geom group of the visual meshes
HIDDEN_GROUP = 3  # geom group of the sole boxes: not drawn (mjvOption shows groups 0-2)
TERRAIN_RGBA = (0.62, 0.6, 0.54, 1.0)
TERRAIN_BASE = 0.05  # m of heightfield drawn below the terrain's lowest point
GL_HELP = (
    "without a display install Mesa's EGL (Debian/Ubuntu: apt-get install libegl1 "
    "libgl1-mesa-dri) and leave MUJOCO_GL unset or egl; with a display, MUJOCO_GL=glfw"
)


# -- OpenGL ---------------------------------------------------------------------------------------
def default_gl() -> str:
    """MUJOCO_GL, set to egl first on Linux when it is unset; call it before mujoco is first
    imported (mujoco reads it then). Returns the backend, lower case ("" when none is set)."""
    if sys.platform.startswith("linux"):
        os.environ.setdefault("MUJOCO_GL", "egl")
    return os.environ.get("MUJOCO_GL", "").strip().lower()


def import_mujoco() -> Any:
    """mujoco, imported once MUJOCO_GL is set (`default_gl`); a ViewerError naming the [train]
    extra without it, or saying what to install when its OpenGL backend breaks the import (an
    invalid MUJOCO_GL, a backend whose library does not load)."""
    backend = default_gl()
    try:
        require("train", "drawing a clip", ViewerError, ("mujoco",))
    except ViewerError:
        raise
    except Exception as exc:  # mujoco imports its backend and lets only an ImportError pass
        raise no_gl(backend, exc) from exc
    import mujoco

    return mujoco


def open_gl(model: mujoco.MjModel, width: int, height: int) -> tuple[Any, Any]:
    """A current OpenGL context of MUJOCO_GL's backend (chosen here, whatever mujoco picked when
    it was imported) and MuJoCo's rendering context of `model` in it; a ViewerError saying what
    to install when either cannot be made."""
    import mujoco

    backend = default_gl()
    context = None
    with warnings.catch_warnings(record=True) as caught:  # GLFW warns before it fails
        warnings.simplefilter("always")
        try:
            context = _context_class(backend)(width, height)
            context.make_current()
            return context, mujoco.MjrContext(model, mujoco.mjtFontScale.mjFONTSCALE_100)
        except Exception as exc:  # each backend fails its own way (ImportError, EGL, GLFW)
            if context is not None:
                with contextlib.suppress(Exception):
                    context.free()
            raise no_gl(backend, exc, [str(w.message) for w in caught]) from exc


def _context_class(backend: str) -> Any:
    if backend == "egl":
        from mujoco.egl import GLContext
    elif backend == "osmesa":
        from mujoco.osmesa import GLContext
    else:
        from mujoco import GLContext  # glfw, or the platform's own
    return GLContext


def check_gl() -> None:
    """Nothing when an OpenGL context can be made for MuJoCo, else its ViewerError."""
    mujoco = import_mujoco()
    model = mujoco.MjModel.from_xml_string("<mujoco/>")
    context, mjr = open_gl(model, 16, 16)
    mjr.free()
    context.free()


def no_gl(backend: str, exc: BaseException, notes: list[str] | None = None) -> ViewerError:
    """The one-line error of a backend that gave no usable context: why, and what to install."""
    reason = "; ".join([*(notes or [])[:2], str(exc) or type(exc).__name__])
    return ViewerError(
        f"no OpenGL context for MuJoCo's offscreen renderer (MUJOCO_GL={backend or 'unset'}: "
        f"{' '.join(reason.split())[:300]}); {GL_HELP}"
    )


# -- the model ------------------------------------------------------------------------------------
def visual_model(
    robot: Robot,
    meshes: list[LinkMesh],
    width: int,
    height: int,
    terrain: TerrainPatch | None = None,
) -> mujoco.MjModel:
    """The robot's MJCF with its visual meshes (group ROBOT_GROUP, never colliding), the sole
    boxes hidden, a checker floor, a sky, a spotlight on the base, a clip's `terrain`, and an
    offscreen buffer of width x height pixels."""
    import mujoco

    spec = mujoco.MjSpec.from_string(robot.mjcf_text)
    for geom in spec.geoms:
        if geom.parent != spec.worldbody:  # the sole boxes: collisions only
            geom.group = HIDDEN_GROUP
    _add_meshes(spec, meshes)
    _dress_scene(spec, robot.spec.root)
    if terrain is not None:
        _add_terrain(spec, terrain)
    spec.visual.global_.offwidth, spec.visual.global_.offheight = width, height
    try:
        return spec.compile()
    except ValueError as exc:
        reason = " ".join(str(exc).split())
        raise ViewerError(
            f"the visual model of robot '{robot.name}' does not compile: {reason}"
        ) from exc


def _add_meshes(spec: mujoco.MjSpec, meshes: list[LinkMesh]) -> None:
    """Each mesh a massless geom in the body of its link, placed by the link's site (the MJCF
    has a site per link frame, named after the link)."""
    import mujoco

    for k, link_mesh in enumerate(meshes):
        site = spec.site(link_mesh.link)
        if site is None:
            continue  # a link the MJCF leaves out
        mesh = spec.add_mesh(name=f"visual_{k}")
        mesh.uservert = link_mesh.vertices.astype(float).ravel()
        mesh.userface = link_mesh.faces.astype(np.int32).ravel()
        mesh.inertia = mujoco.mjtMeshInertia.mjMESH_INERTIA_SHELL  # open meshes compile too
        site.parent.add_geom(
            name=f"visual_{k}",
            type=mujoco.mjtGeom.mjGEOM_MESH,
            meshname=mesh.name,
            pos=site.pos,
            quat=site.quat,
            rgba=[*(c / 255 for c in link_mesh.color), 1.0],
            contype=0,
            conaffinity=0,
            group=ROBOT_GROUP,
            mass=0.0,
        )


def _add_terrain(spec: mujoco.MjSpec, patch: TerrainPatch) -> None:
    """The terrain as a heightfield geom that never collides; the floor plane below its lowest
    point when that lies below the floor (a pit, a gap between stones)."""
    import mujoco

    data, low, span = hfield_data(patch)
    width, depth = patch.size
    field = spec.add_hfield(name="terrain")
    field.size = [width / 2, depth / 2, span, TERRAIN_BASE]
    field.nrow, field.ncol = data.shape
    field.userdata = data.ravel().tolist()
    spec.worldbody.add_geom(
        name="terrain",
        type=mujoco.mjtGeom.mjGEOM_HFIELD,
        hfieldname="terrain",
        pos=[*patch.centre, low],
        rgba=list(TERRAIN_RGBA),
        contype=0,
        conaffinity=0,
    )
    if low < 0:
        for geom in spec.worldbody.geoms:
            if geom.type == mujoco.mjtGeom.mjGEOM_PLANE:
                geom.pos = [geom.pos[0], geom.pos[1], low - TERRAIN_BASE]


def _dress_scene(spec: mujoco.MjSpec, root: str) -> None:
    """A checker floor, a sky gradient, a soft headlight, the world's light without shadows,
    and a spotlight that follows the base (its shadows stay with the robot however far it
    goes)."""
    import mujoco

    checker = spec.add_texture(
        name="checker",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=[0.85, 0.85, 0.83],
        rgb2=[0.66, 0.67, 0.68],
        width=64,
        height=64,
    )
    # texuniform: `texrepeat` textures per metre; a checker texture holds 2 x 2 squares
    floor = spec.add_material(
        name="floor", texuniform=True, texrepeat=[0.5 / CHECKER] * 2, specular=0.1
    )
    floor.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = checker.name
    for geom in spec.worldbody.geoms:
        if geom.type == mujoco.mjtGeom.mjGEOM_PLANE:
            geom.material, geom.rgba = floor.name, [1.0, 1.0, 1.0, 1.0]
    spec.add_texture(
        name="sky",
        type=mujoco.mjtTexture.mjTEXTURE_SKYBOX,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_GRADIENT,
        rgb1=[0.62, 0.76, 0.92],
        rgb2=[0.95, 0.96, 0.98],
        width=256,
        height=256,
    )
    for light in spec.lights:  # the world's: fixed, its shadows would leave the robot
        light.castshadow, light.diffuse, light.specular = False, [0.45] * 3, [0.1] * 3
    spec.body(root).add_light(
        name="follow",
        mode=mujoco.mjtCamLight.mjCAMLIGHT_TRACK,
        type=mujoco.mjtLightType.mjLIGHT_SPOT,
        pos=[-1.0, -0.6, 4.0],
        dir=[0.25, 0.15, -1.0],
        cutoff=40.0,
        diffuse=[0.35] * 3,
        specular=[0.1] * 3,
        castshadow=True,
    )
    spec.visual.headlight.ambient = [0.15] * 3
    spec.visual.headlight.diffuse = [0.25] * 3
    spec.visual.quality.shadowsize = 2048


# -- pictures -------------------------------------------------------------------------------------
class ClipRenderer:
    """MuJoCo's offscreen renderer of one robot: `picture` draws a pose, `draw` a clip frame.

    Makes an OpenGL context (a ViewerError saying what to install when it cannot); close it, or
    use it in a `with` block, to free the context. `option` is the mjvOption pictures are drawn
    with (e.g. `option.geomgroup[ROBOT_GROUP] = 0` leaves the robot out).
    """

    def __init__(
        self,
        robot: Robot,
        config: RenderConfig,
        meshes: list[LinkMesh],
        waypoints: Array | None = None,
        terrain: TerrainPatch | None = None,
    ) -> None:
        mujoco = import_mujoco()
        self.config = config
        self.model = visual_model(robot, meshes, config.width, config.height, terrain)
        self.data = mujoco.MjData(self.model)
        self.jet_sites = [self.model.site(jet.frame).id for jet in robot.spec.jets]
        self.t_max = np.array([jet.t_max for jet in robot.spec.jets])
        self.waypoints = np.zeros((0, 3)) if waypoints is None else np.asarray(waypoints, float)
        self.context: Any
        self.context, self.mjr = open_gl(self.model, config.width, config.height)
        mujoco.mjr_setBuffer(mujoco.mjtFramebuffer.mjFB_OFFSCREEN, self.mjr)
        extra = len(self.jet_sites) + 2 * len(self.waypoints)
        self.scene = mujoco.MjvScene(self.model, maxgeom=self.model.ngeom + extra)
        self.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = config.shadows
        self.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        self.option = mujoco.MjvOption()
        self.camera = mujoco.MjvCamera()
        self.camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.camera.distance, self.camera.elevation = config.distance, config.elevation
        self.camera.azimuth = config.azimuth
        self.viewport = mujoco.MjrRect(0, 0, config.width, config.height)
        self.pixels = np.empty((config.height, config.width, 3), np.uint8)

    def aim(self, orientations: Array, forward: Array) -> None:
        """Look from config.azimuth degrees about the vertical from the robot's mean front over
        base orientations (N, 4) (w, x, y, z); `forward` is its front in the base frame."""
        fronts = np.array([quat_to_matrix(q) @ np.asarray(forward, float) for q in orientations])
        level = fronts[:, :2] / np.maximum(
            np.linalg.norm(fronts[:, :2], axis=1, keepdims=True), 1e-9
        )
        x, y = level.sum(axis=0)
        heading = math.degrees(math.atan2(y, x)) if math.hypot(x, y) > 1e-6 else 0.0
        # MuJoCo's azimuth is the direction the camera looks in: towards the robot
        self.camera.azimuth = heading + self.config.azimuth + 180.0

    def draw(self, motion: Trajectory, index: int, title: str = "") -> np.ndarray:
        """The picture of frame `index` of a Trajectory, `title` and the time since the clip's
        first frame written in its top left corner."""
        qpos = np.concatenate(
            [
                motion.base_position[index],
                motion.base_orientation[index],
                motion.joint_positions[index],
            ]
        )
        seconds = float(motion.time[index] - motion.time[0])
        return self.picture(qpos, motion.thrust[index], title, f"{seconds:.2f} s")

    def picture(self, qpos: Array, thrust: Array, title: str = "", note: str = "") -> np.ndarray:
        """The picture (height, width, 3) uint8 of the robot at `qpos` (MuJoCo's: base position,
        quaternion w x y z, joints), the camera on its base, flames for `thrust` [N] per jet;
        `title` and `note`, when given, in two columns in the top left corner."""
        import mujoco

        model, data, scene = self.model, self.data, self.scene
        data.qpos[:] = qpos
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mj_camlight(model, data)  # the lights follow the base
        self.camera.lookat[:] = data.qpos[:3]
        mujoco.mjv_updateScene(
            model, data, self.option, None, self.camera, mujoco.mjtCatBit.mjCAT_ALL, scene
        )
        self._flames(np.asarray(thrust, float))
        self._waypoints()
        self.context.make_current()
        mujoco.mjr_render(self.viewport, scene, self.mjr)
        if title or note:
            top_left = mujoco.mjtGridPos.mjGRID_TOPLEFT
            font = mujoco.mjtFont.mjFONT_NORMAL
            mujoco.mjr_overlay(font, top_left, self.viewport, title, note, self.mjr)
        mujoco.mjr_readPixels(self.pixels, None, self.viewport, self.mjr)
        return np.flipud(self.pixels).copy()  # OpenGL's rows run bottom up

    def _flames(self, thrust: Array) -> None:
        """A capsule out of each firing nozzle along the exhaust (+z of the jet frame, opposite
        to the force on the robot), THRUST_LENGTH x T/T_max long."""
        share = np.clip(thrust / self.t_max, 0.0, None)
        for site, part in zip(self.jet_sites, share, strict=True):
            if part > 0.01:
                nozzle = self.data.site_xpos[site]
                exhaust = self.data.site_xmat[site].reshape(3, 3)[:, 2]
                end = nozzle + THRUST_LENGTH * part * exhaust
                self._connector(nozzle, end, FLAME_RADIUS, FLAME_RGBA, FLAME_EMISSION)

    def _waypoints(self) -> None:
        """A ball at each waypoint, on a pole down to the floor when it is in the air."""
        for point in self.waypoints:
            self._ball(point, WAYPOINT_RADIUS, WAYPOINT_RGBA, WAYPOINT_EMISSION)
            if point[2] > WAYPOINT_RADIUS:
                floor = np.array([point[0], point[1], 0.0])
                self._connector(point, floor, POLE_RADIUS, WAYPOINT_RGBA, WAYPOINT_EMISSION)

    def _new_geom(self, rgba: tuple[float, ...], emission: float) -> Any:
        """The next free geom of the scene, initialised (None when the scene is full)."""
        import mujoco

        scene = self.scene
        if scene.ngeom >= scene.maxgeom:
            return None
        geom = scene.geoms[scene.ngeom]
        zero, colour = np.zeros(3), np.asarray(rgba, np.float32)
        mujoco.mjv_initGeom(
            geom, mujoco.mjtGeom.mjGEOM_SPHERE, zero, zero, np.eye(3).ravel(), colour
        )
        geom.category, geom.emission = mujoco.mjtCatBit.mjCAT_DECOR, emission
        scene.ngeom += 1
        return geom

    def _connector(
        self, start: Array, end: Array, radius: float, rgba: tuple[float, ...], emission: float
    ) -> None:
        import mujoco

        geom = self._new_geom(rgba, emission)
        if geom is not None:
            capsule = mujoco.mjtGeom.mjGEOM_CAPSULE
            mujoco.mjv_connector(geom, capsule, radius, np.asarray(start), np.asarray(end))

    def _ball(self, centre: Array, radius: float, rgba: tuple[float, ...], emission: float) -> None:
        geom = self._new_geom(rgba, emission)
        if geom is not None:
            geom.size[:] = radius
            geom.pos[:] = centre

    def close(self) -> None:
        """Free the OpenGL resources (once; the context made current first)."""
        if self.context is None:
            return
        self.context.make_current()
        self.mjr.free()
        self.context.free()
        self.context = None

    def __enter__(self) -> ClipRenderer:
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
