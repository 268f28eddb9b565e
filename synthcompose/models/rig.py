"""What posing needs to know of a MakeHuman-skeleton person (``rig: makehuman-default``), measured
once from its bind pose, and the pose builder: joint rotations set by world orientation, limbs
by two-bone inverse kinematics (a hip, knee and ankle; a shoulder, elbow and wrist).

All in O's axes (x forward, y left, z up) at the file's scale; sides are "L" (+y) and "R" (-y).
"""
from __future__ import annotations

import functools
from dataclasses import dataclass

import numpy as np

from .skin import Skin

SIDES = {"L": 1.0, "R": -1.0}
_ARM_JOINTS = ("clavicle", "shoulder01", "upperarm", "lowerarm", "wrist", "finger", "metacarpal")


def rot(axis, angle: float) -> np.ndarray:
    """(3, 3) rotation by ``angle`` radians about ``axis`` (right hand)."""
    a = np.asarray(axis, np.float64)
    a = a / np.linalg.norm(a)
    k = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    return np.eye(3) + np.sin(angle) * k + (1 - np.cos(angle)) * (k @ k)


def unit(v) -> np.ndarray:
    v = np.asarray(v, np.float64)
    return v / max(float(np.linalg.norm(v)), 1e-12)


def frame(a, b) -> np.ndarray:
    """(3, 3) orthonormal columns: ``a`` made unit, ``b`` orthogonalised against it, their cross."""
    a = unit(a)
    b = unit(np.asarray(b, np.float64) - a * float(np.dot(a, b)))
    return np.stack([a, b, np.cross(a, b)], axis=1)


@dataclass(frozen=True)
class RigInfo:
    """Measured from the bind pose: each side's limb lengths, the foot's heel and toe relative to
    the ankle (flat on the ground), the ankle's height above the sole, the torso's half width at
    each height (``widths``: 1 cm bins from the ground, body without arms), the body's front at
    the hips (x), the ground height (the lowest bind vertex) and the stature (bind height)."""

    stature: float
    ground: float
    thigh: float
    shank: float
    upper_arm: float
    forearm: float
    heel: np.ndarray  # (3,) heel point minus ankle head, flat foot
    toe: np.ndarray  # (3,) toe point minus ankle head
    widths: np.ndarray
    hip_front: float

    def width_at(self, z: float) -> float:
        i = int(np.clip((z - self.ground) / 0.01, 0, len(self.widths) - 1))
        return float(self.widths[max(i - 4, 0):i + 5].max())


def _dominant(skin: Skin) -> list[np.ndarray]:
    return [part.joints[np.arange(len(part.joints)), np.argmax(part.weights, axis=1)] for part in skin.parts]


@functools.lru_cache(maxsize=16)
def rig_info(skin: Skin) -> RigInfo:
    h = {n: skin.heads[skin.index(n)] for n in ("upperleg01.L", "lowerleg01.L", "foot.L", "upperarm01.L",
                                               "lowerarm01.L", "wrist.L")}
    pos = np.concatenate([p.positions for p in skin.parts])
    dom = np.concatenate(_dominant(skin))
    arm = np.array([any(n.startswith(a) for a in _ARM_JOINTS) for n in skin.names])
    ground = float(pos[:, 2].min())
    foot = pos[dom == skin.index("foot.L")]
    sole = foot[foot[:, 2] < ground + 0.02 * skin.extents[2]]
    ankle = h["foot.L"]
    heel = sole[np.argmin(sole[:, 0])] - ankle
    toe = sole[np.argmax(sole[:, 0])] - ankle
    heel[2] = toe[2] = ground - ankle[2]
    heel[1] = toe[1] = 0.0
    body = pos[~arm[dom]]
    bins = np.clip(((body[:, 2] - ground) / 0.01).astype(int), 0, None)
    widths = np.zeros(bins.max() + 1)
    np.maximum.at(widths, bins, np.abs(body[:, 1]))
    hip_z = h["upperleg01.L"][2]
    near = body[np.abs(body[:, 2] - hip_z) < 0.05 * skin.extents[2]]
    return RigInfo(
        stature=float(skin.extents[2]), ground=ground,
        thigh=float(np.linalg.norm(h["lowerleg01.L"] - h["upperleg01.L"])),
        shank=float(np.linalg.norm(h["foot.L"] - h["lowerleg01.L"])),
        upper_arm=float(np.linalg.norm(h["lowerarm01.L"] - h["upperarm01.L"])),
        forearm=float(np.linalg.norm(h["wrist.L"] - h["lowerarm01.L"])),
        heel=heel, toe=toe, widths=widths, hip_front=float(near[:, 0].max()))


class PoseBuilder:
    """Joint rotations ``Q`` (J, 3, 3) and the roots' offset, set parent before child."""

    def __init__(self, skin: Skin) -> None:
        self.skin = skin
        self.q = np.tile(np.eye(3), (len(skin.names), 1, 1))
        self.root_offset = np.zeros(3)
        self.info = rig_info(skin)

    def j(self, name: str) -> int:
        return self.skin.index(name)

    def world(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(posed world rotation, posed head) of joint ``name`` under the rotations set so far."""
        chain = []
        k = self.j(name)
        while k >= 0:
            chain.append(k)
            k = int(self.skin.parents[k])
        w, p, prev = np.eye(3), None, None
        for k in reversed(chain):
            if prev is None:
                p = self.skin.heads[k] + self.root_offset
            else:
                p = p + w @ (self.skin.heads[k] - self.skin.heads[prev])
            w = w @ self.q[k]
            prev = k
        return w, p

    def set_world(self, name: str, w: np.ndarray) -> None:
        """Give joint ``name`` the posed world rotation ``w`` (its parent's stays)."""
        parent = int(self.skin.parents[self.j(name)])
        wp = self.world(self.skin.names[parent])[0] if parent >= 0 else np.eye(3)
        self.q[self.j(name)] = wp.T @ w

    def turn(self, name: str, r: np.ndarray) -> None:
        """Rotate joint ``name`` by ``r`` (O's axes) after what it has: world ``r @ W``."""
        self.set_world(name, r @ self.world(name)[0])

    def rest(self, name: str) -> np.ndarray:
        return self.skin.heads[self.j(name)]

    # ------------------------------------------------------------------ limbs
    def limb(self, names: tuple[str, str, str], target, pole, min_bend: float) -> float:
        """Two-bone IK: joints ``names`` (root, middle, end: hip knee ankle or shoulder elbow
        wrist) so that the end's head reaches ``target`` (or as near as the bones allow, bent at
        least ``min_bend`` radians), the middle joint bending towards ``pole``. Each bone is
        turned from its bind direction with the bend plane's normal kept (the bind pose's, or for
        a straight bind limb the one from ``pole``). Returns the bend angle (radians)."""
        a, b, c = (self.rest(n) for n in names)
        l1, l2 = float(np.linalg.norm(b - a)), float(np.linalg.norm(c - b))
        root = self.world(names[0])[1]
        d = np.asarray(target, np.float64) - root
        reach_max = np.sqrt(l1 * l1 + l2 * l2 + 2 * l1 * l2 * np.cos(min_bend))
        dist = float(np.clip(np.linalg.norm(d), abs(l1 - l2) + 1e-4, reach_max))
        dn = unit(d)
        along = (dist * dist + l1 * l1 - l2 * l2) / (2 * dist)
        side = np.sqrt(max(l1 * l1 - along * along, 0.0))
        pole_dir = unit(np.asarray(pole, np.float64) - dn * float(np.dot(dn, pole)))
        mid = root + dn * along + pole_dir * side
        end = root + dn * dist
        u0, f0 = unit(b - a), unit(c - b)
        u1, f1 = unit(mid - root), unit(end - mid)
        n0 = np.cross(u0, f0)
        if np.linalg.norm(n0) < 0.05:  # straight in the bind pose: the plane from the pole
            n0 = np.cross(unit(pole), u0)
        n1 = np.cross(u1, f1)
        if np.linalg.norm(n1) < 1e-6:
            n1 = np.cross(u1, pole_dir)
        self.set_world(names[0], frame(u1, np.cross(n1, u1)) @ frame(u0, np.cross(n0, u0)).T)
        w1 = self.world(names[0])[0]
        for k in self._between(names[0], names[1]):
            self.set_world(k, w1)
        self.set_world(names[1], frame(f1, np.cross(n1, f1)) @ frame(f0, np.cross(n0, f0)).T)
        w2 = self.world(names[1])[0]
        for k in self._between(names[1], names[2]):
            self.set_world(k, w2)
        return float(np.arccos(np.clip(np.dot(u1, f1), -1.0, 1.0)))

    def _between(self, upper: str, lower: str) -> list[str]:
        """The joints strictly between ``upper`` and ``lower`` (twist bones), upper first."""
        out, k = [], int(self.skin.parents[self.j(lower)])
        while k >= 0 and self.skin.names[k] != upper:
            out.append(self.skin.names[k])
            k = int(self.skin.parents[k])
        return out[::-1]

    def spread(self, names: tuple[str, ...], r_axis, angle: float) -> None:
        """Turn the chain ``names`` (parent first) by ``angle`` about ``r_axis`` in all, shared."""
        for n in names:  # children follow their parents: the shares add up along the chain
            self.turn(n, rot(r_axis, angle / len(names)))
