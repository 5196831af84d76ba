"""A dynamic filter that makes a retargeted motion balanceable: the centre of pressure (CoP) its
inverse dynamics needs is kept inside the support by moving the base horizontally.

Each pass checks the motion's physics (motionkit.dataset.physics), takes the CoP error (the
needed CoP minus its nearest point inside the support polygon, shrunk by a margin), and finds the
horizontal centre-of-mass shift that removes it under the cart-table model, CoP = c - (h / g)
c'' (h: the mean CoM height), by least squares over the whole clip (a smooth shift, small where
nothing needs it); the base targets move by that shift and the IK solves the clip again. The
cart-table model leaves out the limbs' momentum, hence a few passes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import spsolve

from motionkit.dataset.physics import GRAVITY, PhysicsReport, nearest_in_polygon
from motionkit.retarget.config import Balance
from motionkit.retarget.targets import Targets
from motionkit.robot.geometry import Array


@dataclass(frozen=True)
class Pass:
    """What one pass measured before it moved the base."""

    cop_inside_share: float  # of frames with a foot on the floor
    cop_error_p95_m: float
    shift_max_m: float  # the largest base shift [m] of the passes before it


def cop_errors(report: PhysicsReport, margin: float) -> tuple[Array, Array]:
    """Per frame the horizontal CoP error [m] (needed CoP minus the nearest point of the support
    shrunk by `margin`; 0 inside) and a weight (1 where a foot is on the floor, else 0)."""
    frames = len(report.cop)
    error, weight = np.zeros((frames, 2)), np.zeros(frames)
    for t in range(frames):
        support = report.support[t]
        if len(support) == 0 or not np.all(np.isfinite(report.cop[t])):
            continue
        weight[t] = 1.0
        error[t] = report.cop[t] - nearest_in_polygon(report.cop[t], support, margin)
    return error, weight


def capped(error: Array, cap: float) -> Array:
    """Errors (T, 2) scaled down to at most `cap` [m] long."""
    size = np.linalg.norm(error, axis=1, keepdims=True)
    return error * np.minimum(1.0, cap / np.maximum(size, 1e-12))


def com_shift(error: Array, weight: Array, time: Array, height: float, config: Balance) -> Array:
    """The horizontal CoM shift (T, 2) [m] whose cart-table CoP change best cancels `error`:
    min sum w (d - k d'' + e)^2 + r0 sum d^2 + r2 sum (k d'')^2, k = height / g."""
    frames = len(time)
    if frames < 3:
        return np.zeros((frames, 2))
    dt = float(np.median(np.diff(time)))
    k = height / GRAVITY
    # second differences with the end rows copied from their neighbours
    second = sparse.diags([1.0, -2.0, 1.0], [0, 1, 2], shape=(frames - 2, frames)).tocsr() / dt**2
    second = sparse.vstack([second[:1], second, second[-1:]]).tocsr()
    cop_change = sparse.eye(frames) - k * second
    w = sparse.diags(weight)
    normal = (
        cop_change.T @ w @ cop_change
        + config.stay * sparse.eye(frames)
        + config.smooth * k**2 * (second.T @ second)
    ).tocsc()
    return np.stack(
        [spsolve(normal, -(cop_change.T @ (weight * error[:, i]))) for i in range(2)], 1
    )


def shift_targets(targets: Targets, shift: Array) -> Targets:
    """The targets with the base (and the human landmarks that follow it) moved horizontally;
    the soles, which the contacts lock, stay."""
    root = targets.root.copy()
    root[:, :2, 3] += shift
    offset = np.concatenate([shift, np.zeros((len(shift), 1))], axis=1)
    knees = targets.knees + offset[:, None, :]
    return replace(targets, root=root, knees=knees)


def balance(
    targets: Targets,
    solve: Callable[[Targets], tuple[Array, Array]],
    check: Callable[[Array, Array], PhysicsReport],
    config: Balance,
    first: tuple[Array, Array] | None = None,
) -> tuple[Targets, Array, Array, list[Pass]]:
    """Filter the motion: `solve` runs the IK on targets, `check` the physics of (base poses,
    joints). Returns the targets and motion of the best pass (most frames with the CoP inside),
    and what each pass measured before it moved the base (the last entry: the last motion).
    `first`: the motion of the unfiltered targets, when solved already."""
    motion = first if first is not None else solve(targets)
    passes: list[Pass] = []
    total = np.zeros((len(targets.time), 2))
    best: tuple[float, Targets, tuple[Array, Array]] | None = None
    for iteration in range(config.passes + 1):
        report = check(*motion)
        error, weight = cop_errors(report, config.margin)
        inside = report.cop_inside[report.loaded]
        size = np.linalg.norm(error, axis=1)[weight > 0]
        share = float(inside.mean()) if inside.size else 1.0
        passes.append(
            Pass(
                cop_inside_share=share,
                cop_error_p95_m=float(np.percentile(size, 95)) if size.size else 0.0,
                shift_max_m=float(np.abs(total).max()),
            )
        )
        if best is None or share > best[0]:
            best = (share, targets, motion)
        if iteration == config.passes or not np.any(size > 0):
            break
        height = float(report.com[:, 2].mean())
        shift = com_shift(capped(error, config.error_cap), weight, targets.time, height, config)
        shift = capped(total + shift, config.max_shift) - total
        total += shift
        targets = shift_targets(targets, shift)
        motion = solve(targets)
    _, targets, motion = best
    return targets, *motion, passes
