"""Contact handling on hard gaits (tests/retarget/gaits.py, written as BVH and read back): a
stylised start-walk-stop, two-footed hops, a travelling one-legged hop, and a heel-and-toe walk
on a floor that is not level with jitter. Each holds the acceptance figures; the contacts follow
the plan; the pieces (detection, hysteresis, locks, weights, config checks) by hand."""

from itertools import pairwise
from pathlib import Path

import numpy as np
import pytest
from gaits import GAITS, THIGH, gait_clip, smoothstep, write_gait

from motionkit.core.errors import RetargetError
from motionkit.mocap import load_mocap
from motionkit.retarget.config import RetargetConfig, Weights
from motionkit.retarget.targets import detect_contacts, hysteresis, lock_offsets
from motionkit.retarget.targets import smoothstep as lock_ramp
from motionkit.robot import ironcub

RATE = 120.0


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("gaits")
    return {name: write_gait(folder, name) for name in GAITS}


def _targets(path: Path, config: RetargetConfig):  # -> motionkit.retarget.targets.Targets
    from motionkit.retarget.points import robot_points
    from motionkit.retarget.targets import RobotGeometry, make_targets

    robot = ironcub()
    geometry = RobotGeometry(robot, robot_points(robot, config.points), config.points.torso_frame)
    clip = load_mocap(path)
    return make_targets(clip.landmarks(), clip.rate, geometry, config)


def _inside(intervals, time: np.ndarray, margin: float) -> np.ndarray:
    """Frames at least `margin` s inside any of the (start, stop) intervals."""
    return np.any([(a + margin <= time) & (time < b - margin) for a, b in intervals], axis=0)


def _between(intervals, end: float) -> list[tuple[float, float]]:
    """The gaps before, between and after sorted (start, stop) intervals, up to `end`."""
    edges = [0.0, *(t for interval in intervals for t in interval), end]
    return list(zip(edges[::2], edges[1::2], strict=True))


# --- the generated clips ---------------------------------------------------------------------


@pytest.mark.parametrize("name", list(GAITS))
def test_gait_files_read_back_as_cmu_clips(name: str, files: dict[str, Path]) -> None:
    clip = load_mocap(files[name])
    gait = GAITS[name]()
    assert clip.rate == RATE and clip.frames == len(gait.time) and not clip.tpose_dropped
    assert clip.units_scale == pytest.approx(0.01)  # centimetres, found from the leg length
    assert clip.landmark_map["l_toe"] == "LeftToeBase" and clip.landmark_map["r_knee"] == "RightLeg"
    made = gait_clip(gait).landmarks()
    for key, value in clip.landmarks().items():
        np.testing.assert_allclose(value, made[key], atol=1e-6)


def test_planted_feet_and_legs_by_hand() -> None:
    """In the flat part of a stance the ankle is at its foothold, 8 cm up, and the ball 15 cm
    ahead, 3 cm up; a heel-first touchdown at -0.15 rad lifts the ankle to
    0.05 sin 0.15 + 0.08 cos 0.15; thighs keep their length."""
    gait = GAITS["start_walk_stop"]()
    marks = gait_clip(gait).landmarks()
    t = gait.time
    for k, side in enumerate("lr"):
        for stance in gait.feet[k]:
            flat = (stance.start + 0.1 <= t) & (t < stance.stop - stance.roll)
            assert flat.sum() >= 30
            foothold = np.tile([stance.x, stance.y, 0.08], (flat.sum(), 1))
            np.testing.assert_allclose(marks[f"{side}_ankle"][flat], foothold, atol=1e-9)
            np.testing.assert_allclose(marks[f"{side}_toe"][flat, 2], 0.03, atol=1e-9)
            np.testing.assert_allclose(marks[f"{side}_toe"][flat, 0], stance.x + 0.15, atol=1e-9)
        thigh = np.linalg.norm(marks[f"{side}_knee"] - marks[f"{side}_hip"], axis=1)
        np.testing.assert_allclose(thigh, THIGH, atol=1e-12)
    touchdown = gait.feet[1][1]
    assert (touchdown.start, touchdown.land) == (1.45, -0.15)
    assert marks["r_ankle"][174, 2] == pytest.approx(0.0865736, abs=1e-6)


def test_hop_flights_are_ballistic_and_land_toe_first() -> None:
    """Flight 1.4-1.8 s: the pelvis peaks at take-off height + g T^2 / 8 = 0.93 + 0.1962 m (a
    hair lower: the reach limit's smooth minimum); at touchdown (1.8 s) the foot is pitched
    0.35 rad toe down about the ball: ankle 0.15 sin 0.35 + 0.08 cos 0.35 = 0.12658 m up."""
    gait = GAITS["hop"]()
    marks = gait_clip(gait).landmarks()
    assert marks["pelvis"][192, 2] == pytest.approx(1.1262, abs=1e-3)  # 1.6 s
    assert marks["l_ankle"][216, 2] == pytest.approx(0.126584, abs=1e-6)  # 1.8 s
    flying = _inside(gait.flights, gait.time, 0.05)
    assert (marks["l_toe"][flying, 2] > 0.04).all() and (marks["r_toe"][flying, 2] > 0.04).all()


# --- what the retargeter makes of them -------------------------------------------------------


@pytest.fixture(scope="module", params=list(GAITS))
def retargeted(request: pytest.FixtureRequest, files: dict[str, Path]) -> tuple[str, dict]:
    """The contact handling end to end: targets, IK, metrics (the stages it lives in; a filter
    that core.retarget may run after them is not part of it)."""
    pytest.importorskip("placo")
    from motionkit.retarget.ik import solve_motion
    from motionkit.retarget.metrics import compute_metrics
    from motionkit.retarget.points import robot_points

    robot, config = ironcub(), RetargetConfig()
    points = robot_points(robot, config.points)
    targets = _targets(files[request.param], config)
    solved = solve_motion(robot, targets, points, config)
    return request.param, compute_metrics(robot, targets, points, solved.base, solved.joints)


def test_gaits_hold_the_acceptance_figures(retargeted: tuple[str, dict]) -> None:
    name, m = retargeted
    assert m["foot_slide_p95_m_s"] <= 0.003, name  # the gate; hard contacts: about 1e-10
    assert m["penetration_max_m"] <= 0.001, name
    assert m["joint_position_violations"] == 0 and m["joint_velocity_violations"] == 0, name
    assert m["feet_error_mean_m"] <= 0.03, name
    assert m["source_slide_p95_m_s"] >= 0.15, name  # the human's feet roll and skid far more


def test_hop_contacts_follow_the_flights(files: dict[str, Path]) -> None:
    """Both feet up in every flight (also the 6 cm rebounds), down between, the same frames for
    both feet (the hop is symmetric), within 0.04 s of the planned touchdowns and take-offs."""
    gait = GAITS["hop"]()
    contacts = _targets(files["hop"], RetargetConfig()).contacts
    t = gait.time
    assert (contacts[:, 0] == contacts[:, 1]).all()
    assert not contacts[_inside(gait.flights, t, 0.04)].any()
    assert contacts[_inside(_between(gait.flights, t[-1] + 1.0), t, 0.04)].all()
    assert (contacts == gait.on_ground()).mean() >= 0.95


def test_one_legged_hop_contacts(files: dict[str, Path]) -> None:
    """The held foot (up from 0.6 s to 4.3 s) is never down in between; the hopping one is up
    in each flight and down once its skid (0.1 s) is over."""
    gait = GAITS["hop_one_leg"]()
    contacts = _targets(files["hop_one_leg"], RetargetConfig()).contacts
    t = gait.time
    assert gait.feet[1][0].stop == 0.6 and gait.feet[1][-1].start == pytest.approx(4.3)
    assert not contacts[(0.75 <= t) & (t < 4.2), 1].any()
    assert not contacts[_inside(gait.flights, t, 0.04), 0].any()
    stances = [(s.start + 0.1, s.stop) for s in gait.feet[0]]
    assert contacts[_inside(stances, t, 0.04), 0].all()


def test_walk_contacts_on_a_floor_that_rises(files: dict[str, Path]) -> None:
    """The heel-and-toe walk's floor rises 3.6 cm over the walk, its markers jitter: every
    planned stance is found (from 0.1 s after touchdown), no swing is taken for one."""
    gait = GAITS["heel_toe_walk"]()
    contacts = _targets(files["heel_toe_walk"], RetargetConfig()).contacts
    t = gait.time
    for k in range(2):
        stances = [(s.start + 0.1, s.stop) for s in gait.feet[k]]
        swings = [(a.stop, b.start) for a, b in pairwise(gait.feet[k])]
        assert contacts[_inside(stances, t, 0.04), k].all()
        assert not contacts[_inside(swings, t, 0.08), k].any()


# --- the pieces, by hand ---------------------------------------------------------------------


def _foot(heights: np.ndarray, xs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Ankle and toe (toe 15 cm ahead, 5 cm lower) of a flat foot at these heights and x."""
    ankle = np.column_stack([xs, np.zeros_like(xs), heights])
    return ankle, ankle + np.array([0.15, 0.0, -0.05])


def test_detection_follows_a_floor_that_rises() -> None:
    """Four 1 s stances, 0.6 m apart, each on floor 1.5 cm higher than the last (0.5 s swings,
    up to 15 cm): all found, no swing taken for one. The standing height is the lowest within
    1 s, so each stance is at most 1.5 cm above it; the clip's lowest would put the last one
    4.5 cm up, above contact_height (3 cm)."""
    t = np.arange(660) / RATE
    steps = sum(smoothstep((t - 1.5 * k - 1.0) / 0.5) for k in range(3))  # 0, 1, 2, 3
    heights = 0.08 + 0.015 * steps + 0.15 * np.sin(np.pi * steps) ** 2
    ankle, toe = _foot(heights, 0.6 * steps)
    contacts = detect_contacts(ankle, toe, t, RetargetConfig())
    phase = (t % 1.5) / 1.5
    assert contacts[phase < 0.6].all()  # standing: the first 0.9 s of each 1.5 s
    assert not contacts[(phase > 0.72) & (phase < 0.94)].any()  # mid-swing
    assert contacts[t > 4.5].all() and 4.0 < t[~contacts].max() < 4.5


def test_detection_hysteresis_keeps_a_contact_through_a_wobble() -> None:
    """A planted foot whose ankle and toe rise 3.3 cm and come back over 0.4 s (under 0.26 m/s):
    above contact_height (3 cm) for 0.08 s but below 1.2 x it, so the contact holds; with no
    hysteresis it breaks there."""
    t = np.arange(240) / RATE
    wobble = 0.033 * np.sin(np.pi * np.clip((t - 0.8) / 0.4, 0.0, 1.0)) ** 2
    ankle, toe = _foot(0.08 + wobble, np.zeros_like(t))
    assert detect_contacts(ankle, toe, t, RetargetConfig()).all()
    strict = detect_contacts(ankle, toe, t, RetargetConfig(contact_hysteresis=1.0))
    assert not strict[(0.97 < t) & (t < 1.03)].any() and strict[t < 0.9].all()


def test_each_foot_stands_on_its_own_ground() -> None:
    """A still foot 2 cm above the other foot's lowest (a skeleton not quite symmetric) is in
    contact; one 30 cm above it (more than ground_range, 8 cm) never is."""
    t = np.arange(120) / RATE
    for raised, expected in ((0.02, True), (0.3, False)):
        ankle, toe = _foot(np.full_like(t, 0.08 + raised), np.zeros_like(t))
        contacts = detect_contacts(ankle, toe, t, RetargetConfig(), lowest=(0.08, 0.03))
        assert (contacts == expected).all()


def test_hysteresis_by_hand() -> None:
    enter = np.array([0, 1, 0, 0, 0, 1, 0, 1, 0], dtype=bool)
    stay = np.array([1, 1, 1, 0, 1, 1, 1, 1, 0], dtype=bool)
    expected = [0, 1, 1, 0, 0, 1, 1, 1, 0]  # a run of `stay` counts from its first `enter`
    assert hysteresis(enter, stay).astype(int).tolist() == expected


def test_lock_offsets_by_hand() -> None:
    """A sole moving 1 cm per frame along x, in contact on frames 10-19, window 4: locked at
    x = 0.10 in the contact; closing in before with smoothstep weights 3 u^2 - 2 u^3 of
    u = 0, 1/4, 1/2, 3/4 (0, 5/32, 1/2, 27/32) on frames 6-9; the last offset (0.10 - 0.19)
    carried out after with weights 27/32, 1/2, 5/32, 0 on frames 20-23."""
    x = np.arange(30) * 0.01
    planar = np.column_stack([x, np.zeros(30), np.zeros(30)])
    contact = (np.arange(30) >= 10) & (np.arange(30) < 20)
    offset, keep, hold = lock_offsets(planar, contact, 4)
    target = x + offset[:, 0]
    rising = np.array([0.0, 5 / 32, 0.5, 27 / 32])
    np.testing.assert_allclose(target[10:20], 0.10, atol=1e-12)
    np.testing.assert_allclose(target[6:10], x[6:10] + rising * (0.10 - x[6:10]), atol=1e-15)
    np.testing.assert_allclose(target[6:10], [0.06, 0.0746875, 0.09, 0.0984375], atol=1e-15)
    np.testing.assert_allclose(target[20:24], x[20:24] - 0.09 * rising[::-1], atol=1e-15)
    np.testing.assert_allclose(keep[6:24], [*rising, *[1.0] * 10, *rising[::-1]], atol=1e-15)
    np.testing.assert_allclose(hold[[9, 10, 19, 20, 22]], [0.0, 1.0, 1.0, 27 / 32, 5 / 32])
    assert not offset[:6].any() and not offset[24:].any()


def test_lock_offsets_share_a_short_gap() -> None:
    """Contacts on frames 0-4 and 7-11 (a 2-frame gap), window 4, the sole moving 0.1 m per
    frame: in the gap the carried-out weights (27/32, 1/2, of the first lock's last offset
    -0.4) and the closing-in ones (1/2, 27/32, toward 0.7) share 1 (both divided by
    1 + 11/32 = 43/32): targets 0.5 + (-0.3375 + 0.1) / (43/32) = 0.5 - 7.6 / 43 and
    0.6 + (-0.2 + 0.084375) / (43/32) = 0.6 - 3.7 / 43."""
    x = np.arange(12) * 0.1
    contact = np.array([1, 1, 1, 1, 1, 0, 0, 1, 1, 1, 1, 1], dtype=bool)
    offset, _, hold = lock_offsets(np.column_stack([x, 0 * x, 0 * x]), contact, 4)
    target = x + offset[:, 0]
    gap = [0.5 - 7.6 / 43, 0.6 - 3.7 / 43]
    np.testing.assert_allclose(target, [0.0] * 5 + gap + [0.7] * 5, atol=1e-12)
    np.testing.assert_allclose(hold[4:8], [1.0, 27 / 43, 16 / 43, 1.0], atol=1e-15)


def test_lock_weights_by_hand() -> None:
    u = np.array([-1.0, 0.0, 0.25, 0.5, 1.0, 2.0])
    assert lock_ramp(u).tolist() == [
        0.0, 0.0, 5 / 32, 0.5, 1.0, 1.0
    ]  # fmt: skip


def test_contact_foot_weights_blend() -> None:
    from motionkit.retarget.tasks import foot_weights

    weights = Weights()
    assert foot_weights(weights, 0.0) == (1000.0, 100.0)
    assert foot_weights(weights, 1.0) == (1e5, 1e4)
    assert foot_weights(weights, 0.5) == pytest.approx((50500.0, 5050.0))


@pytest.mark.parametrize(
    ("values", "message"),
    [
        ({"contact_height": 0.0}, "'contact_height' should be finite and > 0, got 0.0"),
        ({"contact_hysteresis": 0.8}, "'contact_hysteresis' should be finite and >= 1, got 0.8"),
        ({"ground_range": -0.01}, "'ground_range' should be finite and >= 0, got -0.01"),
        ({"contact_speed": float("inf")}, "'contact_speed' should be finite and > 0, got inf"),
        ({"tolerance": 0.0}, "'tolerance' should be finite and > 0, got 0.0"),
        ({"hard_contacts": "yes"}, "'hard_contacts' should be"),
        ({"weights": {"contact_foot_position": -1}}, r"\[weights\]: 'contact_foot_position'"),
    ],
)
def test_contact_settings_are_checked(values: dict, message: str) -> None:
    with pytest.raises(RetargetError, match=f"^recipe.toml: .*{message}"):
        RetargetConfig.from_dict(values, "recipe.toml")
