"""Natural poses of a MakeHuman-skeleton person, drawn from a seeded rng: standing (weight on
one leg; arms hanging, hands in pockets, a phone held at the chest, a bag carried) and walking
(:mod:`.gait`: a continuous phase of the stride); the head turned and tilted. Each pose is a set of
joint rotations (:mod:`.rig`) and a JSON-able description with every parameter drawn.

Rules the poses keep (tests/models/test_people.py): the feet stand on the ground (inverse kinematics
puts the soles on it, flat in standing and in a walking stance), the hands hang clear of the
hips and the arms clear of the torso (the wrist placed beside the body's measured width),
nothing but what is asked for comes from ``rng``.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .arms import DEG, SPINE, hand_of, hang_arm, phone_arm, pocket_arm, round_to, turn_head
from .gait import place_feet, walking
from .mesh import MeshPart, finish_part
from .rig import SIDES, PoseBuilder, rot, unit
from .skin import Skin

KINDS = ("standing", "walking")
#: (variant, share) of standing poses
STANDING = (("relaxed", 0.34), ("pockets", 0.18), ("one-pocket", 0.12), ("phone", 0.2), ("bag", 0.16))
#: share of walking among the poses drawn when none is asked for
WALKING_SHARE = 0.5
#: linear colours of the props
PHONE_RGB = (0.012, 0.012, 0.014)
BAG_RGB = ((0.02, 0.02, 0.022), (0.07, 0.04, 0.022), (0.25, 0.19, 0.12), (0.05, 0.06, 0.09))


@dataclass(frozen=True, eq=False)
class Posed:
    """A drawn pose: joint ``rotations`` (J, 3, 3), the roots' ``root_offset``, the
    ``description`` (JSON-able) and the prop it carries (``None``, or (kind, side, rgb))."""

    rotations: np.ndarray
    root_offset: np.ndarray
    description: dict
    prop: tuple | None = None
    hand: tuple | None = None  # (world rotation, head, hand direction) of the prop's wrist

    def props(self, skin: Skin, meshes) -> tuple[MeshPart, ...]:
        """The prop's mesh (a phone or a bag), in O at the skin's scale, or nothing."""
        if self.prop is None or self.hand is None:
            return ()
        kind, side, rgb = self.prop
        w, wrist, hand_dir = self.hand
        s = skin.extents[2] / 1.75
        if kind == "phone":
            centre = wrist + hand_dir * 0.075 * s
            up = unit(np.array([-0.6, 0.0, 1.0]))  # the screen faces the eyes
            return (box(centre, (hand_dir, np.cross(up, hand_dir), up), (0.075 * s, 0.036 * s, 0.0045 * s), rgb),)
        size = np.array([0.16, 0.055, 0.13]) * s  # half sizes of a bag hanging from the hand
        centre = wrist + hand_dir * 0.06 * s + np.array([0.0, 0.0, -0.015 * s - size[2]])
        return (box(centre, (np.array([1.0, 0, 0]), np.array([0, 1.0, 0]), np.array([0, 0, 1.0])), size, rgb),)


def box(centre, axes, half, rgb) -> MeshPart:
    """A box (flat shaded) centred at ``centre`` with edge directions ``axes`` and half sizes."""
    a = [unit(x) for x in axes]
    pos, nrm, tri = [], [], []
    for axis in range(3):
        for sign in (-1.0, 1.0):
            n = a[axis] * sign
            t1 = a[(axis + 1) % 3] * half[(axis + 1) % 3]
            t2 = a[(axis + 2) % 3] * half[(axis + 2) % 3]
            c = np.asarray(centre, np.float64) + n * half[axis]
            base = len(pos)
            pos.extend([c - t1 - t2, c + t1 - t2, c + t1 + t2, c - t1 + t2])
            nrm.extend([n] * 4)
            tri.extend([[base, base + 1, base + 2], [base, base + 2, base + 3]])
    pos, nrm = np.array(pos), np.array(nrm)
    tri = _outward(pos, np.array(tri), nrm)
    n = len(pos)
    return finish_part(pos, nrm, np.zeros((n, 2)), np.tile([*rgb, 1.0], (n, 1)),
                        np.tile([0.0, 0.5], (n, 1)), tri, None, name="prop")


def _outward(pos, tri, nrm) -> np.ndarray:
    """Triangles wound so their normal agrees with the face normal."""
    out = tri.copy()
    fn = np.cross(pos[tri[:, 1]] - pos[tri[:, 0]], pos[tri[:, 2]] - pos[tri[:, 0]])
    flip = np.einsum("ij,ij->i", fn, nrm[tri[:, 0]]) < 0
    out[flip] = out[flip][:, [0, 2, 1]]
    return out


# ---------------------------------------------------------------------- standing
def standing(b: PoseBuilder, rng: np.random.Generator) -> tuple[dict, tuple | None, str | None]:
    """Weight on one leg, the other foot a little forward and out, both flat; arms by variant."""
    s = b.info.stature / 1.75
    names = [v for v, _ in STANDING]
    shares = np.array([w for _, w in STANDING])
    variant = names[int(rng.choice(len(names), p=shares / shares.sum()))]
    stance = "L" if rng.random() < 0.5 else "R"
    free = "R" if stance == "L" else "L"
    sg = SIDES[stance]
    roll = sg * rng.uniform(1.5, 4.5) * DEG  # the free hip drops
    yaw = rng.uniform(-6, 6) * DEG
    shift = sg * rng.uniform(0.015, 0.04) * s
    b.set_world("root", rot([0, 0, 1], yaw) @ rot([1, 0, 0], roll))
    b.root_offset = np.array([rng.uniform(-0.01, 0.01) * s, shift, 0.0])
    toe_out = rng.uniform(4, 14, 2) * DEG
    feet = {
        stance: (np.array([rng.uniform(-0.02, 0.03) * s, sg * rng.uniform(0.06, 0.1) * s]), yaw + sg * toe_out[0]),
        free: (np.array([rng.uniform(-0.04, 0.16) * s, -sg * rng.uniform(0.08, 0.16) * s]), yaw - sg * toe_out[1]),
    }
    poses = {side: (xy, fyaw, 0.0, "flat") for side, (xy, fyaw) in feet.items()}
    knees = place_feet(b, poses, {stance: rng.uniform(2, 6) * DEG, free: rng.uniform(8, 16) * DEG})
    b.spread(SPINE, [1, 0, 0], -roll * rng.uniform(0.7, 1.1))
    b.spread(SPINE, [0, 1, 0], rng.uniform(-2, 4) * DEG)
    b.spread(SPINE, [0, 0, 1], rng.uniform(-5, 5) * DEG)
    desc = {"pose": "standing", "variant": variant, "weight_on": "left" if stance == "L" else "right",
            "hip_roll_deg": round_to(roll / DEG, 2), "body_yaw_deg": round_to(yaw / DEG, 2), "hip_shift_m": round_to(shift),
            "knee_deg": {("left" if side == "L" else "right"): round_to(k / DEG, 1) for side, k in knees.items()},
            "free_foot_m": [round_to(v) for v in feet[free][0]]}
    prop, hand_side = None, None
    side = "L" if rng.random() < 0.5 else "R"
    other = "R" if side == "L" else "L"
    arms = {}
    if variant in ("pockets", "one-pocket"):
        arms[side] = {"arm": "pocket"} | pocket_arm(b, side, rng)
        if variant == "pockets":
            arms[other] = {"arm": "pocket"} | pocket_arm(b, other, rng)
    elif variant == "phone":
        arms[side] = {"arm": "phone"} | phone_arm(b, side, rng)
        prop, hand_side = ("phone", side, PHONE_RGB), side
    elif variant == "bag":
        rgb = BAG_RGB[int(rng.integers(len(BAG_RGB)))]
        ab = hang_arm(b, side, rng.uniform(-4, 6) * DEG, rng.uniform(4, 12) * DEG, rng.uniform(1, 4) * DEG, 0.13)
        arms[side] = {"arm": "bag", "abduction_deg": round_to(ab / DEG, 1)}
        prop, hand_side = ("bag", side, rgb), side
    for k in ("L", "R"):
        if k not in arms:
            swing, flex = rng.uniform(-6, 8) * DEG, rng.uniform(6, 22) * DEG
            ab = hang_arm(b, k, swing, flex, rng.uniform(0.5, 5) * DEG, 0.05)
            arms[k] = {"arm": "hanging", "swing_deg": round_to(swing / DEG, 1), "elbow_deg": round_to(flex / DEG, 1),
                       "abduction_deg": round_to(ab / DEG, 1)}
    desc["arms"] = {("left" if k == "L" else "right"): v for k, v in sorted(arms.items())}
    if variant == "phone":
        yaw_h, pitch_h = rng.uniform(-8, 8) * DEG + SIDES[side] * 6 * DEG, rng.uniform(20, 34) * DEG
    else:
        yaw_h, pitch_h = rng.uniform(-35, 35) * DEG, rng.uniform(-6, 10) * DEG
    turn_head(b, yaw_h, pitch_h)
    desc |= {"head_yaw_deg": round_to(yaw_h / DEG, 1), "head_pitch_deg": round_to(pitch_h / DEG, 1)}
    return desc, prop, hand_side


def draw_pose(skin: Skin, rng: np.random.Generator, pose: str | None = None) -> Posed:
    """A natural pose drawn from ``rng``: ``pose`` None any, "standing" or "walking"."""
    if pose is not None and pose not in KINDS:
        raise ValueError(f"pose must be one of {', '.join(KINDS)} or None, not {pose!r}")
    kind = pose or ("walking" if rng.random() < WALKING_SHARE else "standing")
    b = PoseBuilder(skin)
    desc, prop, hand_side = (walking if kind == "walking" else standing)(b, rng)
    hand = hand_of(b, hand_side) if hand_side else None
    return Posed(b.q.copy(), b.root_offset.copy(), desc, prop, hand)
