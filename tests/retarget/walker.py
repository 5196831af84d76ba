"""A synthetic human walker for tests: landmarks (m, Z up) of a person walking along +x.

Feet in stance stay planted; swing feet move two steps ahead while lifting 8 cm; the hips move
at constant speed and height; knees bend forward (two-link IK in the sagittal plane)."""

import numpy as np

THIGH, SHANK, FOOT, HIP_Y, ANKLE_HEIGHT, HIP_HEIGHT = 0.42, 0.42, 0.15, 0.09, 0.08, 0.85


def walker(
    seconds: float = 2.0, rate: float = 120.0, step: float = 0.3, cadence: float = 1.8
) -> tuple[dict[str, np.ndarray], float]:
    t = np.arange(round(seconds * rate)) / rate
    hip_x = step * cadence * t
    up = np.array([0.0, 0.0, 1.0])
    landmarks: dict[str, np.ndarray] = {}
    for side, y, phase in (("l", HIP_Y, 0.0), ("r", -HIP_Y, 0.5)):
        cycle = t * cadence / 2 + phase  # one cycle = two steps
        swing = np.clip((cycle % 1.0 - 0.6) / 0.4, 0.0, 1.0)  # 60 % stance, 40 % swing
        foot_x = 2 * step * (np.floor(cycle) + 0.5 * (1 - np.cos(np.pi * swing)) - phase) + step
        ankle = np.stack(
            [foot_x, np.full_like(t, y), ANKLE_HEIGHT + 0.08 * np.sin(np.pi * swing)], 1
        )
        hip = np.stack([hip_x, np.full_like(t, y), np.full_like(t, HIP_HEIGHT)], 1)
        reach = ankle - hip
        distance = np.linalg.norm(reach, axis=1, keepdims=True)
        forward = np.cross(reach / distance, [0.0, 1.0, 0.0])  # perpendicular, toward +x
        bend = np.sqrt(np.maximum(THIGH**2 - (distance / 2) ** 2, 0.0))
        landmarks |= {
            f"{side}_hip": hip,
            f"{side}_knee": hip + reach / 2 + forward * bend,
            f"{side}_ankle": ankle,
            f"{side}_toe": ankle + np.array([FOOT, 0.0, 0.03 - ANKLE_HEIGHT]),
        }
    middle = 0.5 * (landmarks["l_hip"] + landmarks["r_hip"])
    landmarks |= {
        "pelvis": middle,
        "spine": middle + 0.15 * up,
        "chest": middle + 0.35 * up,
        "neck": middle + 0.5 * up,
        "head": middle + 0.65 * up,
    }
    swing_arm = 0.3 * np.sin(np.pi * cadence * t)
    for side, y, sign in (("l", 0.18, -1), ("r", -0.18, 1)):
        shoulder = middle + np.array([0.0, y, 0.45])
        angle = sign * swing_arm
        elbow = shoulder + 0.28 * np.stack([np.sin(angle), 0 * t, -np.cos(angle)], axis=1)
        landmarks |= {
            f"{side}_shoulder": shoulder,
            f"{side}_elbow": elbow,
            f"{side}_wrist": elbow + np.array([0.25, 0.0, 0.0]),
        }
    return landmarks, rate
