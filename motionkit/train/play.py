"""A policy rolled out on the CPU with MuJoCo C, from the standing pose toward waypoints, as
a motion clip.

The physics is the training's MuJoCo backend (`motionkit.train.env.mujoco.BatchPhysics`, one
environment) on the environment's own model (its MJCF, options and substeps per control step).
The observation, the PD targets and the jets are the environment's own functions
(`Env.observe`, `Env.feet_down`, `Env.control`), jitted for one robot and fed the backend's
`Kinematics`. tests/train/test_play.py checks the loop against MJX's `Env.step`.

Waypoints are fed as in training: the current one relative to the base (the observation's last
block), reached when the base comes within `waypoint_radius`; the next one follows. Unlike in
training a waypoint has no deadline: it stays until reached. The run ends after the last
waypoint (not with a watcher: a live viewer may place more), at a fall (the base lower than
`min_base_height` above the surface, a pit read as its rim, or a non-finite state) or after
`seconds`.

With fitted jets (`[env] jet` other than "ideal") the clip holds the commanded throttle [%] of
every jet (its throttle channel) beside the thrust the jet model gave, so that a viewer shows
the engines' lag; the ideal jet has no throttle.

On a terrain (`terrain="KIND[:LEVEL]"`, a policy of the terrain scenario) the robot plays on a
course training did not use (`courses.held_out`, numbered by `seed`): it starts on the pad of
that tile (without a level, the hardest), waypoints given are relative to the tile's centre in
x and y, a random route runs across the tile as training's routes do, and the clip records the
terrain under the robot for `motionkit view` and `motionkit render`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from motionkit.core.errors import TrainError
from motionkit.dataset import write
from motionkit.files.outputs import check_out, claim_out
from motionkit.robot import Robot
from motionkit.train.env import Env, courses, levels, waypoints
from motionkit.train.env import terrain as terrain_lib
from motionkit.train.env.mujoco import BatchPhysics, Kinematics
from motionkit.train.evaluate import first_episode
from motionkit.train.policy import Policy, policy_env

FLYING_SHARE = 0.5  # a way with more steps airborne than this was flown


class Player:
    """One robot of `env` on the training's MuJoCo backend (`BatchPhysics` of one
    environment, one thread) at the environment's control rate, starting at `spawn` (x, y)
    [m] on the ground (None: the keyframe's place). `data` holds live views of its positions
    and velocities (`data.qpos`, `data.qvel`)."""

    def __init__(self, env: Env, spawn: tuple[float, float] | None = None) -> None:
        self.env = env
        self.spawn = spawn
        self.model = env.mj_model
        self.physics = BatchPhysics(env, 1, threads=1)
        fields = self.physics.fields
        self.data = SimpleNamespace(qpos=fields["qpos"][0], qvel=fields["qvel"][0])

        def observe(
            data: Kinematics, thrust: jax.Array, target: jax.Array
        ) -> tuple[jax.Array, jax.Array, jax.Array]:
            data = jax.tree.map(lambda x: x[0], data)
            base = data.qpos[:3]
            lift = base[2] - terrain_lib.surface_at(env.terrain, base[:2])
            return env.observe(data, thrust, target), env.feet_down(data), lift

        def control(jet: Any, thrust: jax.Array, action: jax.Array) -> tuple[Any, ...]:
            state = SimpleNamespace(jet=jet, thrust=thrust)  # what Env.control reads
            ctrl, jet, thrust = env.control(state, action)
            return jet, thrust, ctrl

        self._observe, self._control = jax.jit(observe), jax.jit(control)
        self.throttle: np.ndarray | None = None  # [%] per jet of the last step (fitted jets)
        self.reset(*self.standing())

    def standing(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(qpos, qvel, thrust) of the standing pose: the keyframe at the environment's standing
        posture (no joint noise) moved to the spawn point on the ground, at rest, the jets at
        the low end of initial_thrust (fitted jets: at idle, as the environment starts them)."""
        env = self.env
        qpos = self.model.key("stand").qpos.copy()
        qpos[7:] = np.asarray(env.default_q)
        if self.spawn is not None:
            ground = terrain_lib.height_at(env.terrain, jnp.asarray(self.spawn, jnp.float32))
            qpos[:3] += [*self.spawn, float(ground)]
        thrust = np.minimum(env.config.initial_thrust[0], np.asarray(env.t_max))
        return qpos, np.zeros(self.model.nv), np.maximum(thrust, env.jets.idle)

    def reset(self, qpos: np.ndarray, qvel: np.ndarray, thrust: np.ndarray) -> None:
        """Start at this state (as an episode of the environment starts: the keyframe's other
        values, the link positions of `qpos`, the jet model resting at `thrust`)."""
        self.kinematics = self.physics.place(np.array([0]), qpos[None], qvel[None])
        self.thrust = jnp.asarray(thrust, jnp.float32)
        self.jet = self.env.jets.state_at(self.thrust)

    def observe(self, target: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
        """(observation, feet on the ground, base height above the terrain) now, pursuing
        `target`."""
        target = np.asarray(target, np.float32)
        obs, feet, lift = self._observe(self.kinematics, self.thrust, target)
        return np.asarray(obs), np.asarray(feet), float(lift)

    def control(self, action: Any) -> tuple[Any, jax.Array, jax.Array]:
        """(jet model state, thrust, ctrl) after `action` from the state now (`Env.control`:
        the action clipped, the jets stepped, the PD targets mapped); changes nothing."""
        return self._control(self.jet, self.thrust, action)

    def step(self, action: Any) -> None:
        """One control step: jets and PD targets from `action`, then the environment's
        substeps of MuJoCo physics; `throttle` holds the fitted jets' commanded throttle."""
        self.jet, self.thrust, ctrl = self.control(action)
        self.kinematics = self.physics.step(np.asarray(ctrl)[None])
        env = self.env
        if env.jets.fitted:
            jets = np.clip(np.asarray(action, np.float32)[env.num_joints :], -1.0, 1.0)
            self.throttle = np.asarray(env.jets.throttle(jets), np.float32)


@dataclass
class Leg:
    """The way to one waypoint."""

    target: np.ndarray  # (3,) world frame [m]
    start: float = 0.0  # s, when it became the current waypoint
    reached: float | None = None  # s
    steps: int = 0
    airborne: int = 0  # steps after which both soles were off the ground
    single: int = 0  # steps after which exactly one sole was on the ground
    switches: float = 0.0  # touch-downs plus lift-offs, per foot
    thrust: float = 0.0  # sum over the steps of the mean T / T_max

    @property
    def airborne_share(self) -> float:
        return self.airborne / self.steps if self.steps else 0.0

    @property
    def single_share(self) -> float:
        return self.single / self.steps if self.steps else 0.0

    def switches_per_second(self, control_hz: float) -> float:
        return self.switches * control_hz / self.steps if self.steps else 0.0

    @property
    def thrust_share(self) -> float:
        return self.thrust / self.steps if self.steps else 0.0

    @property
    def how(self) -> str:
        return "flying" if self.airborne_share > FLYING_SHARE else "walking"


@dataclass
class Played:
    """What a rollout did: its frames (one per control step), the ways to the waypoints, how
    it ended, and the wall time it took (compilation excluded)."""

    control_hz: float
    legs: list[Leg]
    qpos: list[np.ndarray] = field(default_factory=list)
    thrust: list[np.ndarray] = field(default_factory=list)
    throttle: list[np.ndarray] = field(default_factory=list)  # commanded [%] (fitted jets)
    target: list[np.ndarray] = field(default_factory=list)  # pursued during the step
    feet_down: list[np.ndarray] = field(default_factory=list)  # after the step
    end: str = "at the time limit"  # how the run ended, after "ended"
    falls: int = 0
    wall_seconds: float = 0.0
    compile_seconds: float = 0.0
    tile: tuple[int, int] | None = None  # (kind index, level) of the course's tile played on

    @property
    def frames(self) -> int:
        return len(self.qpos)

    @property
    def seconds(self) -> float:
        return self.frames / self.control_hz

    @property
    def real_time_factor(self) -> float:
        return self.seconds / self.wall_seconds if self.wall_seconds > 0 else float("inf")

    def record(
        self, qpos: np.ndarray, thrust: np.ndarray, throttle: np.ndarray | None, target: np.ndarray
    ) -> None:
        """Keep a frame (the throttle only with fitted jets)."""
        self.qpos.append(qpos.copy())
        self.thrust.append(thrust)
        if throttle is not None:
            self.throttle.append(throttle)
        self.target.append(target)

    def arrays(self) -> dict[str, np.ndarray]:
        """Time-major (T, 1, ...) arrays shaped like an evaluation's, for `first_episode`."""
        rows = {
            "qpos": self.qpos,
            "thrust": self.thrust,
            "target": self.target,
            "feet_down": self.feet_down,
        }
        if self.throttle:
            rows["throttle"] = self.throttle
        out = {name: np.stack(value)[:, None] for name, value in rows.items()}
        out["done"] = np.zeros((self.frames, 1), bool)
        if self.tile is not None:
            out["kind"], out["level"] = (np.full((self.frames, 1), v) for v in self.tile)
        return out


FrameWatcher = Callable[[np.ndarray, np.ndarray, np.ndarray, np.ndarray], Sequence[np.ndarray]]


def roll_out(
    player: Player,
    act: Callable[[Any], Any],
    route: Sequence[np.ndarray],
    seconds: float,
    *,
    watch: FrameWatcher | None = None,
    real_time: bool = False,
) -> Played:
    """Roll `act` (observation -> action) out from the player's state toward the waypoints of
    `route` for at most `seconds`. `watch(qpos, thrust, feet_down, target)`, called after every
    control step, returns waypoints to add (a live viewer's); with a watcher the run does not
    end after the last waypoint. `real_time` paces the steps with the wall clock."""
    env, config = player.env, player.env.config
    hz = config.control_hz
    legs = [Leg(np.asarray(p, float)) for p in route]
    if not legs:
        raise TrainError("a rollout needs at least one waypoint")
    played = Played(hz, legs)
    index = 0  # the leg pursued; len(legs) once the last is reached
    t_max = np.asarray(env.t_max)

    def current() -> np.ndarray:
        return legs[min(index, len(legs) - 1)].target

    tick = time.perf_counter()
    obs, before, _ = player.observe(current())
    jax.block_until_ready((act(obs), player.control(env.rest_action)))  # compiled, not timed
    played.compile_seconds = time.perf_counter() - tick
    start = time.perf_counter()
    for k in range(round(seconds * hz)):
        target = current()
        player.step(act(obs))
        qpos = player.data.qpos
        if not (np.isfinite(qpos).all() and np.isfinite(player.data.qvel).all()):
            played.falls, played.end = 1, f"with a fall at {(k + 1) / hz:.2f} s (non-finite state)"
            break
        now = (k + 1) / hz
        thrust = np.asarray(player.thrust)
        played.record(qpos, thrust, player.throttle, target)
        leg = legs[index] if index < len(legs) else None
        if leg is not None:
            leg.steps += 1
            leg.thrust += float(np.mean(thrust / t_max))
            if bool(waypoints.reached(qpos[:3], target, config.waypoint_radius)):
                leg.reached, index = now, index + 1
                if index < len(legs):
                    legs[index].start = now
        obs, feet, lift = player.observe(current())
        played.feet_down.append(feet)
        if leg is not None:
            leg.airborne += int(not feet.any())
            leg.single += int(feet.sum() == 1)
            leg.switches += float(np.mean(feet != before))
        before = feet
        if lift < config.min_base_height:
            played.falls, played.end = 1, f"with a fall at {now:.2f} s"
            break
        if watch is not None:
            for point in watch(qpos, thrust, feet, current()):
                legs.append(Leg(np.asarray(point, float), start=now))
        elif index == len(legs):
            played.end = f"after the last waypoint, at {now:.2f} s"
            break
        if real_time:
            time.sleep(max(0.0, start + now - time.perf_counter()))
    played.wall_seconds = time.perf_counter() - start
    return played


def random_route(
    env: Env, count: int, seed: int, start: np.ndarray, tile: levels.Tile | None = None
) -> list[np.ndarray]:
    """`count` waypoints drawn as the environment draws them (ground and air, air_probability
    of them in the air), each following the one before, the first following `start`; on a
    course, across `tile` (`Env.next_waypoint`)."""
    previous = jnp.asarray(start, jnp.float32)
    tile = env.flat_tile if tile is None else tile
    share = jnp.asarray(env.config.air_probability, jnp.float32)
    route = []
    for key in jax.random.split(jax.random.key(seed), count):
        previous = env.next_waypoint(key, previous, share, jnp.asarray(0.0), tile)
        route.append(np.asarray(previous, float))
    return route


def parse_waypoints(text: str) -> list[np.ndarray]:
    """'x,y,z x,y,z ...' [m] as points; a TrainError naming the first bad token."""
    tokens = text.split()
    if not tokens:
        raise TrainError("--waypoints is empty: expected 'x,y,z x,y,z ...' in metres")
    points = []
    for token in tokens:
        try:
            values = [float(part) for part in token.split(",")]
        except ValueError:
            values = []
        if len(values) != 3 or not np.isfinite(values).all():
            raise TrainError(
                f"--waypoints: {token!r} is not a waypoint; expected x,y,z (three finite "
                "numbers in metres, no spaces), waypoints separated by spaces"
            )
        points.append(np.array(values))
    return points


def write_clip(
    path: Path,
    played: Played,
    robot: Robot,
    meta: dict[str, Any],
    course: courses.CourseLayout | None = None,
) -> Path:
    """The rollout as a motion clip (the evaluation rollouts' format, its waypoints and, on a
    `course`, its terrain in the metadata); a TrainError when it is shorter than two frames."""
    trajectory = None
    if played.frames >= 2:
        arrays = played.arrays()
        trajectory = first_episode(arrays, robot, played.control_hz, meta, course)
    if trajectory is None:
        raise TrainError(f"the rollout lasted {played.frames} step(s) ({played.end}): no clip")
    return write(path, trajectory, robot)


def route_for(
    env: Env,
    start: np.ndarray,
    given: Sequence[np.ndarray] | None,
    count: int,
    seed: int,
    tile: levels.Tile | None = None,
) -> list[np.ndarray]:
    """The waypoints given (on a course's `tile`, x and y from its centre), or a random route
    of `count` from `start` (seeded, across the tile)."""
    if given is not None:
        shift = np.zeros(3)
        if tile is not None:
            shift[:2] = np.asarray(env.tile_centre(tile))
        return [np.asarray(p, float) + shift for p in given]
    if count < 1:
        raise TrainError(f"--random-route {count}: at least 1 waypoint")
    return random_route(env, count, seed, start, tile)


def terrain_env(policy: Policy, robot: Robot, terrain: str, seed: int) -> tuple[Env, levels.Tile]:
    """The policy's environment on held-out course `seed` and the tile of 'KIND[:LEVEL]'; a
    TrainError for a policy of flat ground or a bad tile."""
    config = policy.config.env
    if config.scenario != "terrain":
        raise TrainError(
            f"--terrain: {policy.source} was trained on {config.scenario} ground and sees no "
            "height map; a terrain needs a policy of the terrain scenario"
        )
    layout = courses.held_out(courses.CourseLayout.of(config), seed)
    kind, level = courses.parse_tile(terrain, layout)
    env = policy_env(policy, robot, terrain_seed=layout.seed)
    return env, levels.fixed_tile(level, kind)


def play(
    policy: Policy,
    robot: Robot,
    path: Path,
    *,
    route: Sequence[np.ndarray] | None = None,
    count: int = 4,
    seed: int = 0,
    seconds: float = 20.0,
    live: Callable[[Env, list[np.ndarray], np.ndarray], FrameWatcher] | None = None,
    terrain: str | None = None,
) -> tuple[Played, list[np.ndarray]]:
    """Roll `policy` out for `robot` from the standing pose toward waypoints, into a clip.

    The clip goes to `path` (whose folder check_out/claim_out vouch for; nothing is written on
    an error). The run ends after the last waypoint (not with `live`), at a fall or after
    `seconds`.

    Args:
        policy: the policy to roll out (`load_policy`).
        robot: the robot it acts for.
        path: the .mcap clip to write.
        route: waypoints (3,) each, world frame [m]; None: a random route.
        count: the number of waypoints of a random route.
        seed: the seed a random route is drawn with.
        seconds: the longest the rollout lasts [s].
        live: `live(env, route, start)` makes a watcher (a viewer) that sees each step in
            real time and may add waypoints (`start`: the base's first position); None: none,
            and no real-time pacing.
        terrain: 'KIND[:LEVEL]': play on that tile of the held-out course `seed` (a policy of
            the terrain scenario); None: the policy's own ground.

    Returns:
        What the rollout did (frames, the ways to the waypoints, how it ended, timings) and
        the route, given or drawn.

    Raises:
        TrainError: `seconds` not > 0, a folder of `path` that cannot take the clip, a policy
            for another robot layout, a random route of fewer than 1 waypoint, an empty
            route, or a rollout shorter than two frames.
    """
    if not (np.isfinite(seconds) and seconds > 0):
        raise TrainError(f"--seconds {seconds}: expected a duration > 0")
    check_out(path.parent, [path.name], TrainError)
    tile = None
    if terrain is None:
        env = policy_env(policy, robot)
        player = Player(env)
    else:
        env, tile = terrain_env(policy, robot, terrain, seed)
        x, y = np.asarray(env.tile_centre(tile), float)
        player = Player(env, (x, y))
    drawn = route is None
    route = route_for(env, player.data.qpos[:3].copy(), route, count, seed, tile)
    watch = None if live is None else live(env, route, player.data.qpos[:3].copy())
    played = roll_out(
        player, policy.act_fn(), route, seconds, watch=watch, real_time=watch is not None
    )
    meta = {
        "clip": path.stem,
        "policy": str(policy.source),
        "seconds": seconds,
        "seed": seed if drawn else None,
        "end": played.end,
    }
    if tile is not None:
        played.tile = (int(tile.kind), int(tile.level))
        meta["seed"] = seed
    claim_out(path.parent, [path.name], TrainError)
    write_clip(path, played, robot, meta, env.course)
    return played, route


def report(played: Played) -> list[str]:
    """What a rollout did, in lines: each waypoint (when and how reached, thrust), how it
    ended, falls and the real-time factor."""
    lines = []
    for k, leg in enumerate(played.legs, 1):
        x, y, z = leg.target
        head = f"waypoint {k} ({x:.2f}, {y:.2f}, {z:.2f}) m: "
        if not leg.steps:
            lines.append(head + "not pursued")
            continue
        way = (
            f"{leg.how} (airborne {100 * leg.airborne_share:.0f} % of the way, on one foot "
            f"{100 * leg.single_share:.0f} %, "
            f"{leg.switches_per_second(played.control_hz):.1f} contact switches per foot per "
            f"second), thrust {100 * leg.thrust_share:.1f} % of T_max"
        )
        if leg.reached is None:
            lines.append(head + f"not reached in {leg.steps / played.control_hz:.2f} s, {way}")
        else:
            took = leg.reached - leg.start
            lines.append(head + f"reached at {leg.reached:.2f} s (after {took:.2f} s), {way}")
    lines.append(f"ended {played.end}; falls: {played.falls}")
    lines.append(
        f"simulated {played.seconds:.2f} s in {played.wall_seconds:.2f} s of wall time: "
        f"{played.real_time_factor:.1f}x real time (compilation, {played.compile_seconds:.1f} s, "
        "not counted)"
    )
    return lines
