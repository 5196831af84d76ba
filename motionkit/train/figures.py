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

On a course (`kinds`: its tile kinds) also: the share of episodes whose route was done (its
waypoints reached in turn, none missed) without a fall, the airborne share over holes (pits
and the gaps between stones), the thrust per metre moved (N s / m: the jets' impulse per metre
the base moved), and with `levels` the mean level of each kind's environments
(`terrain_level_KIND`: the curriculum's progress).
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from motionkit.train.env import StepInfo


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
            "thrust_per_metre": thrust.sum() / control_hz / jnp.maximum(info.moved.sum(), 1e-6),
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
    }
    return figures | course
