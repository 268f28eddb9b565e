"""The arms and the head of a posed person (:mod:`.poses`, :mod:`.gait`): an arm hanging clear of
the body, a hand in a front pocket, a phone held at the chest, the head turned; in O's axes at the
file's scale."""
from __future__ import annotations

import numpy as np

from .rig import SIDES, PoseBuilder, rot, unit

SPINE = ("spine05", "spine04", "spine03", "spine02", "spine01")
NECK = ("neck01", "neck02", "neck03", "head")
DEG = np.pi / 180.0
#: the elbow's head this far (metres at 1.75 m) outside the body's width at its height: half an
#: arm's thickness in a sleeve
ELBOW_CLEAR_M = 0.065


def round_to(x: float, nd: int = 3) -> float:
    return round(float(x), nd)


def hang_arm(b: PoseBuilder, side: str, swing: float, flex: float, extra: float, margin: float) -> float:
    """The arm of ``side`` hanging, swung forward by ``swing`` (radians, negative: back), the
    elbow bent ``flex``, the wrist ``margin`` (metres at 1.75 m) and the elbow an arm's
    thickness clear of the body's width at their heights, plus ``extra`` radians of abduction.
    Returns the abduction (radians)."""
    info, sgn, s = b.info, SIDES[side], b.info.stature / 1.75
    shoulder = b.world(f"upperarm01.{side}")[1]
    reach = np.sqrt(info.upper_arm ** 2 + info.forearm ** 2 + 2 * info.upper_arm * info.forearm * np.cos(flex))
    ab = 0.0
    for _ in range(3):  # the width wanted depends on the wrist's and the elbow's heights
        z = shoulder[2] - reach * np.cos(ab) * np.cos(swing)
        wrist = (info.width_at(z) + margin * s - sgn * shoulder[1]) / reach
        ze = shoulder[2] - info.upper_arm * np.cos(ab) * np.cos(swing)
        elbow = (info.width_at(ze) + ELBOW_CLEAR_M * s - sgn * shoulder[1]) / info.upper_arm
        ab = float(np.arcsin(np.clip(max(wrist, elbow), 0.0, 0.8)))
    ab += extra
    v = rot([0, 1, 0], -swing) @ np.array([0.0, sgn * np.sin(ab), -np.cos(ab)])
    b.limb((f"upperarm01.{side}", f"lowerarm01.{side}", f"wrist.{side}"), shoulder + reach * v,
           np.array([-1.0, 0.35 * sgn, 0.0]), flex)
    return ab


def pocket_arm(b: PoseBuilder, side: str, rng: np.random.Generator) -> dict:
    """The hand of ``side`` in the trousers' front pocket: the wrist at the hip's front side,
    a little above the hip joint, the elbow bent out and back."""
    info, sgn, s = b.info, SIDES[side], b.info.stature / 1.75
    hip = b.world(f"upperleg01.{side}")[1]
    z = hip[2] + rng.uniform(0.02, 0.07) * s
    front = b.world("root")[0] @ np.array([info.hip_front * rng.uniform(0.55, 0.8), 0, 0])
    rest_y = abs(b.rest(f"upperleg01.{side}")[1])
    target = np.array([hip[0] + front[0], hip[1] + sgn * (info.width_at(z) - rest_y), z])
    bend = b.limb((f"upperarm01.{side}", f"lowerarm01.{side}", f"wrist.{side}"), target,
                  np.array([-0.7, sgn * 1.0, -0.2]), 25 * DEG)
    return {"elbow_deg": round_to(bend / DEG, 1)}


def phone_arm(b: PoseBuilder, side: str, rng: np.random.Generator) -> dict:
    """The hand of ``side`` holding a phone in front of the chest, the elbow down at the side."""
    sgn, s = SIDES[side], b.info.stature / 1.75
    shoulder = b.world(f"upperarm01.{side}")[1]
    target = shoulder + np.array([rng.uniform(0.22, 0.28), -sgn * rng.uniform(0.05, 0.11), -rng.uniform(0.24, 0.32)]) * s
    bend = b.limb((f"upperarm01.{side}", f"lowerarm01.{side}", f"wrist.{side}"), target,
                  np.array([-0.3, sgn * 1.0, -0.8]), 30 * DEG)
    return {"elbow_deg": round_to(bend / DEG, 1)}


def turn_head(b: PoseBuilder, yaw: float, pitch: float) -> None:
    b.spread(NECK, [0, 0, 1], yaw)
    b.spread(NECK, b.world("head")[0] @ np.array([0.0, 1.0, 0.0]), pitch)


def hand_of(b: PoseBuilder, side: str) -> tuple:
    w, p = b.world(f"wrist.{side}")
    rest_dir = unit(b.rest(f"finger3-1.{side}") - b.rest(f"wrist.{side}"))
    return w, p, unit(w @ rest_dir)
