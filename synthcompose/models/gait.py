"""The legs: feet put on the ground by inverse kinematics (:func:`place_feet`, standing and
walking), and a walking stride at a continuous phase (:func:`walking`).

A stride of length S (one foot's step to its next step, in the pelvis' frame): each foot is on
the ground for a share BETA of the cycle, moving back from +S BETA / 2 to -S BETA / 2 under the hip;
it lands on its heel (toes up, the heel the pivot), stands flat, rolls onto its toes before it
lifts off (heel up, the toes the pivot), then swings forward clear of the ground. The pelvis sits
as high as the legs reach with the stance knee a little bent (so it bobs), turns and sways with
the stride; the arms swing against the legs.
"""
from __future__ import annotations

import numpy as np

from .arms import SPINE, hang_arm, turn_head
from .rig import SIDES, PoseBuilder, rot

#: share of the cycle a foot is on the ground
BETA = 0.62
#: a stance foot lands on its heel over this share of its stance, and rolls onto its toes after
HEEL_STRIKE, HEEL_OFF = 0.1, 0.72
DEG = np.pi / 180.0


def foot_target(b: PoseBuilder, xy, yaw: float, pitch: float, pivot: str) -> tuple[np.ndarray, np.ndarray]:
    """(ankle head, foot world rotation) of a foot on the ground at ``xy`` (where its ankle is when
    flat), turned ``yaw`` about z and pitched ``pitch`` (positive: toes down) about its heel
    (``pivot`` "heel"), its toes ("toe") or flat ("flat")."""
    info = b.info
    yaw_r = rot([0, 0, 1], yaw)
    w = yaw_r @ rot([0, 1, 0], pitch)
    flat = np.array([xy[0], xy[1], info.ground - info.heel[2]])
    if pivot == "flat":
        return flat, yaw_r
    point = info.heel if pivot == "heel" else info.toe
    contact = flat + yaw_r @ point
    return contact - w @ point, w


def place_feet(b: PoseBuilder, feet: dict, bends: dict) -> dict:
    """Put each leg's foot where ``feet[side]`` says: (xy, yaw, pitch, pivot) for a foot on the
    ground (:func:`foot_target`) or (ankle xyz, yaw, pitch, "air") for a swinging one. The roots
    are lowered until every leg reaches its foot with the knee bent at least ``bends[side]``;
    then each leg is solved (the knee towards the foot's forward). Returns the knee angles."""
    info = b.info
    targets = {}
    for side, (where, yaw, pitch, pivot) in feet.items():
        if pivot == "air":
            targets[side] = (np.asarray(where, np.float64), rot([0, 0, 1], yaw) @ rot([0, 1, 0], pitch), yaw)
        else:
            ankle, w = foot_target(b, where, yaw, pitch, pivot)
            targets[side] = (ankle, w, yaw)
    drop = []
    for side, (ankle, _, _) in targets.items():
        hip = b.world(f"upperleg01.{side}")[1]
        bend = bends.get(side, 0.0)
        reach = np.sqrt(info.thigh ** 2 + info.shank ** 2 + 2 * info.thigh * info.shank * np.cos(bend)) * 0.999
        flat = min(float(np.linalg.norm((ankle - hip)[:2])), reach * 0.98)
        drop.append(ankle[2] + np.sqrt(reach ** 2 - flat ** 2) - hip[2])
    b.root_offset = b.root_offset + np.array([0.0, 0.0, min(min(drop), 0.02 * info.stature)])
    knees = {}
    for side, (ankle, w, yaw) in targets.items():
        pole = rot([0, 0, 1], yaw) @ np.array([1.0, 0.0, 0.0])
        knees[side] = b.limb((f"upperleg01.{side}", f"lowerleg01.{side}", f"foot.{side}"), ankle, pole,
                             bends.get(side, 0.0))
        b.set_world(f"foot.{side}", w)
    return knees


def _stance(b: PoseBuilder, t: float, stride: float, y: float, yaw: float, hs: float, to: float):
    """(xy, yaw, pitch, pivot) of a foot at share ``t`` of its stance."""
    x = stride * BETA / 2 * (1 - 2 * t)
    if t < HEEL_STRIKE:
        return (x, y), yaw, -hs * (1 - t / HEEL_STRIKE) ** 2, "heel"
    if t > HEEL_OFF:
        return (x, y), yaw, to * ((t - HEEL_OFF) / (1 - HEEL_OFF)) ** 1.5, "toe"
    return (x, y), yaw, 0.0, "flat"


def _smooth(u: float) -> float:
    return u * u * (3 - 2 * u)


def foot_at(b: PoseBuilder, psi: float, stride: float, y: float, yaw: float, hs: float, to: float,
            clearance: float):
    """A leg's foot at its own phase ``psi`` (0: heel strike) for :func:`place_feet`."""
    if psi < BETA:
        return _stance(b, psi / BETA, stride, y, yaw, hs, to)
    u = (psi - BETA) / (1 - BETA)
    a0, _ = foot_target(b, *_stance(b, 1.0, stride, y, yaw, hs, to)[:1], yaw, to, "toe")
    a1, _ = foot_target(b, *_stance(b, 0.0, stride, y, yaw, hs, to)[:1], yaw, -hs, "heel")
    e = _smooth(u)
    pitch = to + (-hs - to) * _smooth(min(u * 1.4, 1.0))
    ankle = a0 + (a1 - a0) * e
    w = rot([0, 0, 1], yaw) @ rot([0, 1, 0], pitch)
    lowest = min((w @ b.info.heel)[2], (w @ b.info.toe)[2])
    ankle[2] = max(ankle[2] + clearance * np.sin(np.pi * u), b.info.ground - lowest + 0.004 * b.info.stature)
    return ankle, yaw, pitch, "air"


def walking(b: PoseBuilder, rng: np.random.Generator) -> tuple[dict, None, None]:
    """A walking pose at a phase drawn from ``rng`` (see the module docstring)."""
    info, s = b.info, b.info.stature / 1.75
    phase = float(rng.random())
    stride = info.stature * rng.uniform(0.62, 0.78)
    arm_swing = rng.uniform(0.4, 1.0)
    hs, to = rng.uniform(8, 16) * DEG, rng.uniform(20, 32) * DEG
    width, clearance = rng.uniform(0.06, 0.09) * s, rng.uniform(0.025, 0.045) * s
    toe_out = rng.uniform(3, 10, 2) * DEG
    yaw_amp, roll_amp, lean = rng.uniform(3, 6) * DEG, rng.uniform(1.5, 3.5) * DEG, rng.uniform(2, 6) * DEG
    c, sn = np.cos(2 * np.pi * phase), np.sin(2 * np.pi * phase)
    pelvis_yaw, roll = yaw_amp * c, -roll_amp * sn
    b.set_world("root", rot([0, 0, 1], pelvis_yaw) @ rot([1, 0, 0], roll))
    b.root_offset = np.array([0.0, -0.015 * s * sn, 0.0])
    feet, bends = {}, {}
    for k, side in enumerate(("R", "L")):
        psi = (phase + 0.5 * k) % 1.0
        sgn = SIDES[side]
        feet[side] = foot_at(b, psi, stride, sgn * width, sgn * toe_out[k], hs, to, clearance)
        bends[side] = 4 * DEG if psi < BETA else 0.0
    knees = place_feet(b, feet, bends)
    b.spread(SPINE, [0, 0, 1], -0.6 * pelvis_yaw)
    b.spread(SPINE, [1, 0, 0], -roll)
    b.spread(SPINE, [0, 1, 0], lean)
    amp = arm_swing * rng.uniform(18, 30) * DEG
    arms = {}
    for side, swing in (("R", -amp * c), ("L", amp * c)):
        flex = rng.uniform(14, 24) * DEG + 0.8 * max(swing, 0.0)
        ab = hang_arm(b, side, swing, flex, rng.uniform(1, 4) * DEG, 0.05)
        arms["right" if side == "R" else "left"] = {"swing_deg": round(swing / DEG, 1), "elbow_deg": round(flex / DEG, 1),
                                                    "abduction_deg": round(ab / DEG, 1)}
    yaw_h, pitch_h = rng.uniform(-20, 20) * DEG, rng.uniform(-4, 8) * DEG
    turn_head(b, yaw_h, pitch_h)
    desc = {"pose": "walking", "variant": "walk", "phase": round(phase, 4), "stride_m": round(stride, 3),
            "arm_swing": round(float(arm_swing), 3), "step_width_m": round(width, 3),
            "lean_deg": round(lean / DEG, 2), "pelvis_yaw_deg": round(pelvis_yaw / DEG, 2),
            "knee_deg": {("left" if k == "L" else "right"): round(v / DEG, 1) for k, v in knees.items()},
            "arms": arms, "head_yaw_deg": round(yaw_h / DEG, 1), "head_pitch_deg": round(pitch_h / DEG, 1)}
    return desc, None, None
