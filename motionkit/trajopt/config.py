"""The trajectory-optimisation config: frozen dataclasses, defaults here, filled from TOML recipes.

A recipe (trajopt/*.toml) has top-level keys of `TrajoptConfig` and the tables [scenario],
[weights], [contacts], [jets], [solver] and [replay]. The CLI overrides single scenario fields.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field, fields
from pathlib import Path
from typing import Any

from motionkit.core.checks import check, refusal
from motionkit.core.errors import TrajoptError
from motionkit.core.tomlfile import load, read_toml

SCENARIOS = ("takeoff", "walk_to_fly", "flight_to_waypoint", "landing", "jet_jump")
STARTS = ("stand", "hover")
ENDS = ("stand", "hover")
ORACLES = ("loqo", "quality-function", "probing")  # IPOPT's mu_oracle values
GAINS = ("position_kp", "position_kd", "orientation_kp", "orientation_kd")  # of [replay]


@dataclass(frozen=True)
class Scenario:
    """Boundary conditions and waypoints. Positions are world coordinates [m] of the centre of
    mass; the robot starts at the origin facing its spec's forward direction (-x for iRonCub)."""

    name: str = "takeoff"
    knots: int = 40
    start: str = "stand"  # stand: the spec posture on the floor; hover: at `start_position`
    start_position: tuple[float, float, float] = (0.0, 0.0, 1.0)  # hover start only
    end: str = "hover"  # hover: CoM at `target`, at rest; stand: on the floor below `target`
    target: tuple[float, float, float] = (0.0, 0.0, 1.0)  # stand end: only x, y count
    # One step before anything else (walk_to_fly): foot side ('' = none), length along the
    # forward direction [m], the knot fraction where it lands, swing clearance [m].
    step_foot: str = ""
    step_length: float = 0.2
    step_land: float = 0.3
    step_clearance: float = 0.03
    # A jump (jet_jump): every sole corner at least `apex_clearance` [m] above the floor at the
    # knot fraction `apex_at`; 0 = none.
    apex_clearance: float = 0.0
    apex_at: float = 0.5
    thrust_fraction: float = 1.0  # the jets' thrust limit as a fraction of T_max
    kind: str = ""  # dataset label; default: from the scenario name

    def __post_init__(self) -> None:
        from motionkit.dataset.trajectory import KINDS

        check(self, TrajoptError, SCENARIOS, "name")
        check(self, TrajoptError, STARTS, "start")
        check(self, TrajoptError, ENDS, "end")
        check(self, TrajoptError, ("", "left", "right"), "step_foot")
        check(self, TrajoptError, ("", *KINDS), "kind")
        if self.knots < 8:
            raise refusal(TrajoptError, "knots", "at least 8", self.knots)
        check(self, TrajoptError, "finite", "start_position", "target", "step_length")
        check(self, TrajoptError, ">= 0", "step_clearance", "apex_clearance")
        check(self, TrajoptError, "in (0, 1)", "step_land", "apex_at")
        check(self, TrajoptError, "in (0, 1]", "thrust_fraction")


@dataclass(frozen=True)
class Weights:
    """Cost weights (of squared, scaled terms; only their ratios matter)."""

    com_acceleration: float = 1.0  # (m/s^2)^2
    com_velocity: float = 0.1  # (m/s)^2
    angular_momentum: float = 1.0  # (kg m^2/s)^2 / 10^2
    angular_momentum_rate: float = 1.0
    joint_velocity: float = 0.1  # (rad/s)^2
    posture: float = 1.0  # rad^2
    base_orientation: float = 10.0  # quaternion distance from upright
    contact_force: float = 0.01  # (N / (m g / 8))^2
    thrust: float = 0.01  # (N / 100 N)^2
    thrust_rate: float = 0.1  # (N/s / 100 N/s)^2
    throttle_rate: float = 0.1  # (%/s / 100 %/s)^2
    # Exact penalty on sum f_z c_z (f_z in m g / 8, c_z in m): drives the relaxed
    # complementarity to zero without making the constraint itself degenerate.
    complementarity: float = 10.0

    def __post_init__(self) -> None:
        check(self, TrajoptError, ">= 0", *(item.name for item in fields(self)))


@dataclass(frozen=True)
class Contacts:
    mu: float = 0.33  # friction pyramid (published setting)
    # Relaxed complementarity f_z c_z <= eps, f_z in units of m g / 8: the homotopy solves with
    # each value in turn, warm-started from the previous solution (walk_to_fly.toml has its
    # own). Steps of 10x: the solution at 1e-2, its feet still pressing through a centimetre of
    # relaxation, is far from the one at 1e-6 (a jump's cost rose by 45 % between them), and a
    # direct step took 100-340 iterations (the jumps, take-offs); in steps of 10x each took
    # 5-70 (take-offs, landings, jumps) and the four together about as many as the one.
    eps: tuple[float, ...] = (1e-2, 1e-3, 1e-4, 1e-5, 1e-6)
    slip_eps: float = 1e-4  # no slip while loaded: |f_z * step of the corner| <= this [m]

    def __post_init__(self) -> None:
        check(self, TrajoptError, "> 0", "mu", "eps", "slip_eps")
        check(self, TrajoptError, "non-empty", "eps")


@dataclass(frozen=True)
class Jets:
    model: str = "p250"  # 'p250': second-order model with throttle input; 'rate': Tdot input
    max_rate: float = 300.0  # N/s, the bound on Tdot of the 'rate' model

    def __post_init__(self) -> None:
        check(self, TrajoptError, ("p250", "rate"), "model")
        check(self, TrajoptError, "> 0", "max_rate")


@dataclass(frozen=True)
class Solver:
    dt: float = 0.0  # a fixed time step [s]; 0: optimised within [dt_min, dt_max]
    dt_min: float = 0.05
    dt_max: float = 0.1
    max_joint_velocity: float = 7.0  # rad/s (published bound), and the robot's own limits
    hessian: str = "exact"  # or 'limited-memory'
    tol: float = 1e-6
    constr_viol_tol: float = 1e-6
    max_iter: int = 500
    max_cpu_time: float = 600.0  # s per IPOPT call
    print_level: int = 5  # IPOPT's; 0 = quiet
    warm_start: bool = True  # warm-start each homotopy step from the previous one
    mu_strategy: str = "adaptive"  # IPOPT's barrier update: 'monotone' or 'adaptive'
    # IPOPT's mu_oracle (adaptive barrier update) of the first, cold homotopy step; IPOPT's own
    # default here, 'loqo' in walk_to_fly.toml (why: there). Warm steps always use the default.
    cold_mu_oracle: str = "quality-function"
    options: dict[str, Any] = field(default_factory=dict)  # further IPOPT options, verbatim

    def __post_init__(self) -> None:
        check(self, TrajoptError, ("exact", "limited-memory"), "hessian")
        check(self, TrajoptError, ("monotone", "adaptive"), "mu_strategy")
        check(self, TrajoptError, ORACLES, "cold_mu_oracle")
        check(self, TrajoptError, ">= 0", "dt", "print_level")
        check(self, TrajoptError, "> 0", "dt_min", "dt_max", "max_joint_velocity", "tol")
        check(self, TrajoptError, "> 0", "constr_viol_tol", "max_cpu_time")
        check(self, TrajoptError, ">= 1", "max_iter")
        if self.dt_min > self.dt_max:
            raise refusal(TrajoptError, "dt_min", f"<= dt_max ({self.dt_max})", self.dt_min)


@dataclass(frozen=True)
class Replay:
    """Base feedback of the stabilised MuJoCo replay (replay.py): the desired acceleration of the
    base is kp (plan - actual) + kd (plan velocity - actual velocity), per unit mass for the
    position and per unit inertia (about the CoM) for the orientation; 0 turns a term off.

    The attitude loop is four times as fast as the position loop (both critically damped). The
    near-vertical jets meet a horizontal force only by thrusting the chest jets against the arm
    jets, which also pitches the robot: with a slower attitude loop that coupling made the hover
    of walk_to_fly.toml oscillate in pitch, growing until the base was 0.1 m off the plan at
    6.0 s (orientation gains 100 / 20) or 8.4 s (225 / 30) and 2 m off at the end."""

    position_kp: float = 25.0  # 1/s^2
    position_kd: float = 10.0  # 1/s
    orientation_kp: float = 400.0  # 1/s^2
    orientation_kd: float = 40.0  # 1/s
    # The weight of the moment about the vertical in the allocation's least squares (the others
    # weigh 1 per N and per N m). Near-vertical jets turn the robot about the vertical only
    # through their small horizontal components (about 0.1 N m per N at hover), so with weight 1
    # the fit gave that moment up for small force residuals: the take-off recipe's base ended
    # 0.14 rad off the planned orientation, mostly in yaw (0.33 at worst); with 3, 0.04 (0.07),
    # the base position errors unchanged.
    yaw_weight: float = 3.0
    max_base_error: float = 0.1  # m: the largest stabilised base error of a trackable plan

    def __post_init__(self) -> None:
        check(self, TrajoptError, ">= 0", *GAINS)
        check(self, TrajoptError, "> 0", "yaw_weight", "max_base_error")


@dataclass(frozen=True)
class TrajoptConfig:
    rate: float = 50.0  # Hz of the written clip (resampled from the knots)
    scenario: Scenario = Scenario()
    weights: Weights = Weights()
    contacts: Contacts = Contacts()
    jets: Jets = Jets()
    solver: Solver = Solver()
    replay: Replay = Replay()

    def __post_init__(self) -> None:
        check(self, TrajoptError, "> 0", "rate")

    @classmethod
    def from_toml(cls, path: Path) -> TrajoptConfig:
        return cls.from_dict(read_toml(path, "config", TrajoptError), str(path))

    @classmethod
    def from_dict(cls, data: dict[str, Any], source: str = "<config>") -> TrajoptConfig:
        config = load(cls, data, source, TrajoptError)
        check_ipopt_options(config.solver.options, source)
        return config

    def with_scenario(self, **changes: Any) -> TrajoptConfig:
        """The same config with some scenario fields replaced (CLI overrides)."""
        scenario = asdict(self.scenario) | changes
        return TrajoptConfig.from_dict(self.to_dict() | {"scenario": scenario}, "<command line>")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @property
    def kind(self) -> str:
        default = {"walk_to_fly": "takeoff", "flight_to_waypoint": "flight", "jet_jump": "jump"}
        return self.scenario.kind or default.get(self.scenario.name, self.scenario.name)


def check_ipopt_options(options: dict[str, Any], source: str) -> None:
    """A TrajoptError naming `source` and the first of the verbatim IPOPT options that IPOPT
    refuses (an unknown name, a value of the wrong type or an invalid setting), found by
    building a one-variable solver with each (milliseconds). Without CasADi: not checked here
    (a solve names the missing extra)."""
    if not options:
        return
    try:
        import casadi as cs
    except ImportError:
        return
    from motionkit.runtime.silence import quiet_c_output

    x = cs.SX.sym("x")
    for name, value in options.items():
        try:
            with quiet_c_output():  # IPOPT prints the option's documentation
                cs.nlpsol("probe", "ipopt", {"x": x, "f": x**2}, {"ipopt": {name: value}})
        except RuntimeError as exc:
            text = str(exc)
            reason = (
                "IPOPT has no such option"
                if "No such IPOPT option" in text
                else "a value of the wrong type for IPOPT"
                if "type mismatch" in text
                else "not a setting IPOPT accepts"
            )
            raise TrajoptError(f"{source}: [solver.options] {name} = {value!r}: {reason}") from None
