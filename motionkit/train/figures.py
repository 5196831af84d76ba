"""The figures of a rollout, computed in one place for training and evaluation alike.

Per step (means over every step and environment): the task reward and its terms, the
horizontal speed toward the waypoint, the share of steps on one foot, touch-downs plus
lift-offs per foot per second, the airborne share, the thrust per T_max (also over the airborne
steps alone), the airborne share on the way to ground waypoints and to air ones; on the way to
ground waypoints, the mean thrust of the jet that pushes most (per T_max) and the least and
most any foot is down (the two feet's stance shares). Per episode:
over the
episodes that ended in the rollout (their length, waypoints, falls); when none ended, over the
episodes still running, as far as they got (a partial figure, so that a rollout shorter than
an episode still reports one).

The thrust per metre moved (N s / m: the jets' impulse, summed over the jets, per metre the
base moved horizontally). On a course (`kinds`: its tile kinds) also: the share of episodes
whose route was done (its waypoints reached in turn, none missed) without a fall, the airborne
share over holes (pits and the gaps between stones), and with `levels` the mean level of each
kind's environments (`terrain_level_KIND`: the curriculum's progress).

The transitions (`transition_figures`, evaluations only: NumPy over time-major (T, N) records,
one column per environment, an episode ending at a step whose `done` is set). A flight is a run
of at least MIN_FLIGHT_S airborne (both soles off the ground) in a row within an episode; the
way to a waypoint starts at the episode's first step or the step after a waypoint was reached
or replaced.
- take-off [s]: for a flight that starts (lift-off: airborne after a step on the ground) while
  the robot pursues an air waypoint, from the jets' first rise on that way (the first step at
  which the mean jet command, `Jets.command_share`, is above RISE after a step at or below it;
  an episode starts with its jets at rest) to the lift-off, both steps counted. Not counted
  when the command did not rise on that way before the lift-off.
- landing [s]: for a flight that ends (touch-down: a sole down after it) while the robot
  pursues a ground waypoint, from the start of the descent to the touch-down: the descent
  starts after the flight's last step that left the base at air-waypoint level (above
  `air_level`, the height that tells an air waypoint from a ground one,
  `waypoints.in_air`). Not counted when the base stayed below that level (a hop).
Each is the mean over an episode's transitions, then over the episodes with at least one
(nan when none has one).
"""

from __future__ import annotations

from collections.abc import Iterator

import jax
import jax.numpy as jnp
import numpy as np

from motionkit.train.env import StepInfo

MIN_FLIGHT_S = 1.0  # s airborne in a row: a flight (as flight_1s_share counts one), not a hop
RISE = 0.1  # the share of the jets' command range above rest that marks them as risen


def rollout_figures(
    info: StepInfo,
    thrust: jax.Array,
    t_max: jax.Array,
    control_hz: float,
    kinds: tuple[str, ...] = (),
    levels: bool = True,
) -> dict[str, jax.Array]:
    """The figures of time-major (T, N, ...) step records and thrusts (T, N, jets); on a
    course of these tile `kinds` the terrain's too (the levels with `levels`)."""
    done = info.done
    ended = done.sum()
    last = jnp.zeros_like(done).at[-1].set(True)
    counted = jnp.where(ended > 0, done, last)  # the steps whose episode figures count
    episodes = counted.sum()
    hits, missed = info.hit.sum(), info.timed_out.sum()
    falls = (done & ~info.truncated).sum()
    air = info.air_target
    usage = (thrust / t_max).mean(-1)  # (T, N): the mean over the jets

    def per_episode(x: jax.Array) -> jax.Array:
        return (x * counted).sum() / episodes

    def share(part: jax.Array, whole: jax.Array) -> jax.Array:
        return jnp.where(whole > 0, part / jnp.maximum(whole, 1), jnp.nan)

    terms = {f"reward_{name}": value.mean() for name, value in info.terms.items()}
    ground = ~air
    # on the way to ground waypoints: each jet's mean thrust, each foot's share of steps down
    jets_to_ground = (thrust / t_max * ground[..., None]).sum((0, 1)) / jnp.maximum(ground.sum(), 1)
    stance = (info.feet_down * ground[..., None]).sum((0, 1)) / jnp.maximum(ground.sum(), 1)
    course = {}
    if kinds:
        fell = done & ~info.truncated
        course = {
            "route_success_share": per_episode(info.route_done & ~fell),
            "airborne_share_over_hole": share(
                (info.airborne & info.over_hole).sum(), info.over_hole.sum()
            ),
        }
        if levels:
            for k, name in enumerate(kinds):
                mine = info.kind == k
                course[f"terrain_level_{name}"] = share((info.level * mine).sum(), mine.sum())
    figures = terms | {
        "task_reward": info.task_reward.mean(),
        "approach_speed": info.approach_speed.mean(),
        "single_support_share": (info.feet_down.sum(-1) == 1).mean(),
        "contact_switches_per_second": info.switches.mean() * control_hz,
        "airborne_share": info.airborne.mean(),
        "airborne_share_to_ground": share((info.airborne & ~air).sum(), (~air).sum()),
        "airborne_share_to_air": share((info.airborne & air).sum(), air.sum()),
        "thrust_usage": usage.mean(),
        "thrust_usage_airborne": share((usage * info.airborne).sum(), info.airborne.sum()),
        "thrust_usage_to_ground_max_jet": jnp.where(ground.any(), jets_to_ground.max(), jnp.nan),
        "stance_share_min_foot": jnp.where(ground.any(), stance.min(), jnp.nan),
        "stance_share_max_foot": jnp.where(ground.any(), stance.max(), jnp.nan),
        "episodes": episodes.astype(jnp.float32),
        "episode_seconds": per_episode(info.episode_steps) / control_hz,
        "waypoints_per_episode": per_episode(info.episode_reached),
        "air_waypoints_per_episode": per_episode(info.episode_air_reached),
        # episodes with at least 1 s airborne in a row (a take-off that stays up)
        "flight_1s_share": per_episode(info.episode_longest_flight >= round(control_hz)),
        "seconds_to_waypoint": share(info.hit_steps.sum(), hits) / control_hz,
        "waypoints_missed_share": share(missed, hits + missed),
        "falls": falls,
        "falls_per_episode": falls / episodes,
        "prior_reset_share": share(info.prior_reset.sum(), ended),
        "thrust_per_metre": thrust.sum() / control_hz / jnp.maximum(info.moved.sum(), 1e-6),
    }
    return figures | course


# -- transitions (evaluations) ----------------------------------------------------------------
def transition_figures(
    arrays: dict[str, np.ndarray], command: np.ndarray, air_level: float, control_hz: float
) -> dict[str, float]:
    """takeoff_seconds and landing_seconds (module doc) of an evaluation's records: `arrays`
    with "done", "airborne", "air_target", "hit", "timed_out" and "base_lift" (T, N), and the
    mean jet `command` (T, N) as a share of its range above rest."""
    min_steps = max(1, round(MIN_FLIGHT_S * control_hz))
    takeoffs, landings = [], []
    for episode in _episodes(arrays, command):
        flights = [(a, b) for a, b in _runs(episode["airborne"]) if b - a >= min_steps]
        up = [t for a, _ in flights if (t := _takeoff_steps(episode, a)) is not None]
        down = [
            t for a, b in flights if (t := _landing_steps(episode, a, b, air_level)) is not None
        ]
        if up:
            takeoffs.append(np.mean(up) / control_hz)
        if down:
            landings.append(np.mean(down) / control_hz)
    return {"takeoff_seconds": _mean(takeoffs), "landing_seconds": _mean(landings)}


def _episodes(arrays: dict[str, np.ndarray], command: np.ndarray) -> Iterator[dict]:
    """Each episode's records (1-D, its steps) of every environment, as far as recorded."""
    records = {name: np.asarray(arrays[name]) for name in ("airborne", "air_target", "base_lift")}
    records["command"] = np.asarray(command)
    done = np.asarray(arrays["done"], bool)
    changed = np.asarray(arrays["hit"], bool) | np.asarray(arrays["timed_out"], bool)
    for n in range(done.shape[1]):
        ends = np.flatnonzero(done[:, n]) + 1
        for start, end in zip([0, *ends], [*ends, done.shape[0]], strict=True):
            if end > start:
                episode = {name: value[start:end, n] for name, value in records.items()}
                episode["new_way"] = np.concatenate([[True], changed[start : end - 1, n]])
                yield episode


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) of each run of True in a 1-D boolean array."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1), strict=True))


def _takeoff_steps(episode: dict, lift_off: int) -> int | None:
    """Steps from the jets' first rise on the way to the lift-off (at step `lift_off`), both
    counted; None when it is no take-off (from the episode's start, toward a ground waypoint)
    or the jets did not rise on that way."""
    if lift_off == 0 or not episode["air_target"][lift_off]:
        return None
    way = int(np.flatnonzero(episode["new_way"][: lift_off + 1])[-1])
    risen = episode["command"] > RISE
    before = np.concatenate([[False], risen[:-1]])  # at rest before the episode
    rises = np.flatnonzero(risen & ~before)
    rises = rises[(rises >= way) & (rises <= lift_off)]
    return int(lift_off - rises[0] + 1) if len(rises) else None


def _landing_steps(episode: dict, start: int, end: int, air_level: float) -> int | None:
    """Steps from the descent's start to the touch-down after flight [start, end); None when
    it is no landing (the episode ended in the air, toward an air waypoint) or the base
    stayed below `air_level`."""
    if end >= len(episode["airborne"]) or episode["air_target"][end]:
        return None
    high = np.flatnonzero(episode["base_lift"][start:end] > air_level)
    return int(end - (start + high[-1])) if len(high) else None


def _mean(values: list[float]) -> float:
    return float(np.mean(values)) if values else float("nan")
