"""The engines' lag in the viewer, for clips with a throttle channel (fitted jets in `motionkit
play` and the evaluation rollouts, trajopt flights): per jet, the commanded throttle and the
thrust it gives, as two bars at the current frame (`EngineBars`) and as a time plot of both
(`lag_plot`). A throttle step shows as a jump of the throttle bar that the thrust bar follows
later and more slowly (the engine's dead time and spool-up).

Both are shares of their full range: throttle / 100 % and thrust / T_max.
"""

from __future__ import annotations

import numpy as np
import viser
import viser.uplot

from motionkit.dataset import Trajectory
from motionkit.robot.geometry import Array
from motionkit.viewer.sources import literal

THROTTLE_COLOR, THRUST_COLOR = "blue", "orange"  # the bars'
THROTTLE_STROKE, THRUST_STROKE = "#1c7ed6", "#fd7e14"  # the plot's lines (the same hues)


def engine_shares(motion: Trajectory, t_max: Array) -> tuple[np.ndarray, np.ndarray] | None:
    """(throttle / 100 %, thrust / T_max), each (frames, jets), or None without a throttle."""
    if motion.throttle is None or not motion.thrust.shape[1]:
        return None
    throttle = np.asarray(motion.throttle, float) / 100.0
    return throttle, np.asarray(motion.thrust, float) / np.asarray(t_max, float)


def _percent(share: float) -> float:
    """A share as a bar's value (0 to 100)."""
    return float(np.clip(100.0 * share, 0.0, 100.0))


class EngineBars:
    """Per jet a line of numbers and two bars (throttle, then thrust) in the GUI folder
    "Engines"; `show` sets them to one frame's values."""

    def __init__(self, gui: viser.GuiApi, jet_names: tuple[str, ...], t_max: Array) -> None:
        self.t_max = np.asarray(t_max, float)
        self.names = tuple(literal(name) for name in jet_names)  # as Markdown shows them
        self.folder = gui.add_folder("Engines")
        self.labels, self.throttle, self.thrust = [], [], []
        with self.folder:
            gui.add_markdown(
                "Per jet: the commanded throttle (blue, % of 100) and the thrust (orange, % "
                "of T_max). The thrust follows a throttle step late and slowly: the engine's lag."
            )
            for _ in jet_names:
                self.labels.append(gui.add_markdown(""))
                self.throttle.append(gui.add_progress_bar(0.0, color=THROTTLE_COLOR))
                self.thrust.append(gui.add_progress_bar(0.0, color=THRUST_COLOR))

    def show(self, throttle: Array, thrust: Array) -> None:
        """One frame: `throttle` [%] and `thrust` [N], per jet."""
        for j, name in enumerate(self.names):
            u, force = float(throttle[j]), float(thrust[j])
            share = force / self.t_max[j]
            self.labels[j].content = (
                f"**{name}**: throttle {u:.0f} %, thrust {force:.0f} N ({100 * share:.0f} % "
                "of T_max)"
            )
            self.throttle[j].value = _percent(u / 100.0)
            self.thrust[j].value = _percent(share)

    def remove(self) -> None:
        self.folder.remove()


def lag_plot(
    gui: viser.GuiApi, name: str, time: Array, throttle: Array, thrust: Array
) -> viser.GuiUplotHandle:
    """A time plot of one jet's throttle / 100 % and thrust / T_max."""
    series = (
        viser.uplot.Series(label="time [s]"),
        viser.uplot.Series(label="throttle / 100 %", stroke=THROTTLE_STROKE, width=1),
        viser.uplot.Series(label="thrust / T_max", stroke=THRUST_STROKE, width=1),
    )
    data = tuple(np.asarray(v, float) for v in (time, throttle, thrust))
    return gui.add_uplot(data, series, title=f"{name}: throttle and thrust", aspect=1.6)
