"""The cast's people: skinned GLBs posed by linear blend skinning at run time
(synthcompose.models.skinning / poses / gait), their assets, their clothes' colours, and the
renderer's bounded model cache."""
import json
from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import Delaunay

from synthcompose.look.appearance import draw_appearance
from synthcompose.models import Model, posable, posed_model
from synthcompose.models.gait import BETA, HEEL_OFF, HEEL_STRIKE
from synthcompose.models.poses import draw_pose
from synthcompose.models.skinning import Skin, SkinPart, pose_skin, read_skin, skinning_matrices

from ..tolerances import PEOPLE_ARM_INSIDE_MAX, PEOPLE_FLAT_DEG, PEOPLE_GROUND_M, PEOPLE_LBS_EPS, PEOPLE_REST_EPS_M

PEOPLE = Path(__file__).resolve().parents[2] / "assets" / "cast" / "people"
ENTRIES = sorted(PEOPLE.glob("*/entry.json"))
SIZE = (("height", 1.75),)


def _skin(entry: Path) -> Skin:
    e = json.loads(entry.read_text())
    return read_skin(str(entry.parent / e["model"]), e["up"], e["forward"])


def _first() -> tuple[str, Skin]:
    e = json.loads(ENTRIES[0].read_text())
    path = str(ENTRIES[0].parent / e["model"])
    return path, read_skin(path, e["up"], e["forward"])


# ---------------------------------------------------------------------- skinning itself
def _two_bones() -> Skin:
    """Bone 0 from the origin up to (0, 0, 1), bone 1 from (0, 0, 1) on; four vertices: on bone 0
    only, on bone 1 only, half and half, and 3/4 + 1/4."""
    pos = np.array([[0.1, 0, 0.5], [0.1, 0, 1.5], [0.1, 0, 1.0], [0.0, 0.2, 1.2]])
    joints = np.array([[0, 0, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0], [1, 0, 0, 0]])
    weights = np.array([[1, 0, 0, 0], [1, 0, 0, 0], [0.5, 0.5, 0, 0], [0.75, 0.25, 0, 0]], np.float32)
    part = SkinPart("m", pos, np.tile([1.0, 0, 0], (4, 1)), joints, weights, np.array([[0, 1, 2], [1, 2, 3]]),
                    (1, 1, 1, 1), 0.0, 0.5)
    return Skin("two-bones", ("a", "b"), np.array([-1, 0]), np.array([[0, 0, 0], [0, 0, 1.0]]), (part,), (0, 1),
                np.array([0.1, 0.2, 1.0]))


def _rz(deg):
    a = np.radians(deg)
    return np.array([[np.cos(a), -np.sin(a), 0], [np.sin(a), np.cos(a), 0], [0, 0, 1.0]])


def _rx(deg):
    a = np.radians(deg)
    return np.array([[1.0, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]])


def test_linear_blend_skinning_of_two_bones_is_exact():
    skin = _two_bones()
    rot = np.stack([_rz(90), _rx(90)])  # bone 0 turned 90 deg about z, bone 1 then 90 deg about x
    (pos, nrm), = pose_skin(skin, rot, root_offset=(1.0, 0, 0))
    m0 = lambda v: _rz(90) @ v + [1.0, 0, 0]  # noqa: E731
    w1 = _rz(90) @ _rx(90)
    m1 = lambda v: w1 @ (np.asarray(v) - [0, 0, 1.0]) + _rz(90) @ [0, 0, 1.0] + [1.0, 0, 0]  # noqa: E731
    want = [m0(skin.parts[0].positions[0]), m1(skin.parts[0].positions[1]),
            0.5 * m0([0.1, 0, 1.0]) + 0.5 * m1([0.1, 0, 1.0]), 0.75 * m1([0, 0.2, 1.2]) + 0.25 * m0([0, 0.2, 1.2])]
    np.testing.assert_allclose(pos, np.array(want), atol=PEOPLE_LBS_EPS)
    np.testing.assert_allclose(nrm[0], _rz(90) @ [1.0, 0, 0], atol=PEOPLE_LBS_EPS)


@pytest.mark.parametrize("entry", ENTRIES, ids=[e.parent.name for e in ENTRIES])
def test_rest_pose_reproduces_the_bind_mesh(entry):
    skin = _skin(entry)
    eye = np.tile(np.eye(3), (len(skin.names), 1, 1))
    for part, (pos, nrm) in zip(skin.parts, pose_skin(skin, eye)):
        np.testing.assert_allclose(pos, part.positions, atol=PEOPLE_REST_EPS_M)


# ---------------------------------------------------------------------- the people shipped
@pytest.mark.parametrize("entry", ENTRIES, ids=[e.parent.name for e in ENTRIES])
def test_each_person_loads_and_is_within_limits(entry):
    e = json.loads(entry.read_text())
    assert e["class"] == "person" and e["kind"] == "person" and e["rig"] == "makehuman-default"
    assert {"sex", "age", "build", "hair", "clothes"} <= set(e["body"])
    glb = entry.parent / e["model"]
    assert glb.stat().st_size < 1_200_000  # about 1 MB a person
    assert (entry.parent / "LICENSE").read_text().startswith("Creative Commons Legal Code\n\nCC0 1.0 Universal")
    assert "8cf9645b975a98eea056b140df11a1d278da0d10" in (entry.parent / "SOURCE.txt").read_text()
    assert posable(str(glb))
    model, pose = posed_model(str(glb), tuple(e["size"].items()), e["up"], e["forward"], np.random.default_rng(0))
    assert 10_000 <= model.triangles <= 40_000
    names = {p.name for p in model.parts}
    assert {"skin", "hair", "clothes_top", "clothes_bottom", "shoes"} <= names
    assert 1.55 <= e["size"]["height"] <= 1.95
    assert 1.4 <= model.extents[2] <= 1.95 and pose["pose"] in ("standing", "walking")


def test_the_cast_varies():
    bodies = [json.loads(e.read_text())["body"] for e in ENTRIES]
    assert len(bodies) >= 8
    assert {b["sex"] for b in bodies} == {"female", "male"}
    assert {b["age"] for b in bodies} == {"teen", "adult", "elderly"}
    assert len({b["skin"] for b in bodies}) >= 4 and len({b["build"] for b in bodies}) >= 3
    assert len({b["hair"] for b in bodies}) >= 6 and len({b["clothes"] for b in bodies}) >= 8


# ---------------------------------------------------------------------- poses
def _feet(skin: Skin, rotations, root_offset):
    """Per side: (lowest z of the foot's vertices, tilt of the foot from flat in degrees)."""
    mats = skinning_matrices(skin, rotations, root_offset)
    posed = pose_skin(skin, rotations, root_offset)
    ground = min(p.positions[:, 2].min() for p in skin.parts)
    out = {}
    for side in ("L", "R"):
        j = skin.index(f"foot.{side}")
        low = min(float(pos[p.joints[np.arange(len(p.joints)), np.argmax(p.weights, 1)] == j][:, 2].min(initial=9))
                  for p, (pos, _) in zip(skin.parts, posed))
        up = mats[j][:, :3] @ np.array([0, 0, 1.0])
        out[side] = (low - ground, float(np.degrees(np.arccos(np.clip(up[2], -1, 1)))))
    return out


@pytest.mark.parametrize("kind", ["standing", "walking"])
def test_feet_stand_on_the_ground_flat(kind):
    _, skin = _first()
    for seed in range(12):
        posed = draw_pose(skin, np.random.default_rng(seed), kind)
        feet = _feet(skin, posed.rotations, posed.root_offset)
        lows = [low for low, _ in feet.values()]
        assert min(lows) == pytest.approx(0.0, abs=PEOPLE_GROUND_M), (seed, feet)
        assert min(lows) > -PEOPLE_GROUND_M
        if kind == "standing":  # both feet down, flat
            for low, tilt in feet.values():
                assert abs(low) < PEOPLE_GROUND_M and tilt < PEOPLE_FLAT_DEG, (seed, feet)
        else:  # the foot in the middle of its stance is flat on the ground
            for side, shift in (("R", 0.0), ("L", 0.5)):
                psi = (posed.description["phase"] + shift) % 1.0
                if HEEL_STRIKE * BETA < psi < HEEL_OFF * BETA:
                    low, tilt = feet[side]
                    assert abs(low) < PEOPLE_GROUND_M and tilt < PEOPLE_FLAT_DEG, (seed, side, feet)


def test_poses_differ_and_keys_follow_them():
    path, _ = _first()
    keys, ids = set(), set()
    for seed in range(60):
        model, pose = posed_model(path, SIZE, "+y", "+z", np.random.default_rng(seed))
        keys.add(model.key)
        ids.add(pose["pose_id"])
        json.dumps(pose)  # JSON-able for the record
    assert len(keys) == len(ids) == 60
    model2, pose2 = posed_model(path, SIZE, "+y", "+z", np.random.default_rng(5))
    model1, pose1 = posed_model(path, SIZE, "+y", "+z", np.random.default_rng(5))
    assert pose1 == pose2 and model1.key == model2.key  # reproducible from the seed
    kinds = {posed_model(path, SIZE, "+y", "+z", np.random.default_rng(s))[1]["variant"] for s in range(40)}
    assert kinds == {"walk", "relaxed", "pockets", "one-pocket", "phone", "bag"}


def _torso_and_arms(skin: Skin, posed):
    """The posed torso's vertices (spine joints') and the arms' (upper and lower arm joints'),
    less the shoulder and the armpit (within half the upper arm below the shoulder joint, where arm
    and torso meet by construction)."""
    spine = [skin.index(n) for n in ("spine05", "spine04", "spine03", "spine02", "spine01")]
    arms = [j for j, n in enumerate(skin.names) if n.startswith(("upperarm", "lowerarm"))]
    mats = skinning_matrices(skin, posed.rotations, posed.root_offset)
    shoulder_z = min(float((mats[skin.index(f"upperarm01.{s}")] @ np.append(skin.heads[skin.index(f"upperarm01.{s}")], 1))[2])
                     for s in ("L", "R"))
    upper = float(np.linalg.norm(skin.heads[skin.index("lowerarm01.L")] - skin.heads[skin.index("upperarm01.L")]))
    torso, arm = [], []
    for part, (pos, _) in zip(skin.parts, pose_skin(skin, posed.rotations, posed.root_offset)):
        dom = part.joints[np.arange(len(part.joints)), np.argmax(part.weights, 1)]
        torso.append(pos[np.isin(dom, spine)])
        arm.append(pos[np.isin(dom, arms) & (pos[:, 2] < shoulder_z - upper / 2)])
    return np.concatenate(torso), np.concatenate(arm)


def _inside_slices(torso: np.ndarray, points: np.ndarray, dz: float = 0.03, shrink: float = 0.9) -> np.ndarray:
    """Whether each point lies inside the torso's cross-section at its height (the 2D hull of
    the torso's vertices in 3 cm slices, shrunk 10 %: skin and sleeves touch)."""
    out = np.zeros(len(points), bool)
    for z0 in np.arange(torso[:, 2].min(), torso[:, 2].max(), dz):
        t = torso[(torso[:, 2] >= z0) & (torso[:, 2] < z0 + dz)][:, :2]
        sel = (points[:, 2] >= z0) & (points[:, 2] < z0 + dz)
        if len(t) < 8 or not sel.any():
            continue
        c = t.mean(0)
        out[sel] = Delaunay(c + (t - c) * shrink).find_simplex(points[sel][:, :2]) >= 0
    return out


@pytest.mark.slow
@pytest.mark.parametrize("entry", ENTRIES, ids=[e.parent.name for e in ENTRIES])
def test_arms_stay_outside_the_torso(entry):
    skin = _skin(entry)
    for seed in range(8):
        posed = draw_pose(skin, np.random.default_rng(seed))
        torso, arm = _torso_and_arms(skin, posed)
        inside = float(_inside_slices(torso, arm).mean())
        assert inside < PEOPLE_ARM_INSIDE_MAX, (seed, posed.description["variant"], inside)


def test_an_arm_through_the_torso_is_caught():
    """The clearance measure sees an arm swung across the body (the left arm's wrist put at the
    right hip)."""
    from synthcompose.models.poses import Posed
    from synthcompose.models.rig import PoseBuilder

    _, skin = _first()
    b = PoseBuilder(skin)
    b.limb(("upperarm01.L", "lowerarm01.L", "wrist.L"), b.world("upperleg01.R")[1] + [0.0, 0.05, 0.1],
           np.array([0.0, 1.0, 0.0]), 0.3)
    torso, arm = _torso_and_arms(skin, Posed(b.q, b.root_offset, {}))
    assert _inside_slices(torso, arm).mean() > 3 * PEOPLE_ARM_INSIDE_MAX


def test_pose_can_be_asked_for_and_a_bad_one_is_refused():
    path, skin = _first()
    assert posed_model(path, SIZE, "+y", "+z", np.random.default_rng(1), "walking")[1]["pose"] == "walking"
    assert posed_model(path, SIZE, "+y", "+z", np.random.default_rng(1), "standing")[1]["pose"] == "standing"
    with pytest.raises(ValueError, match="pose must be one of"):
        draw_pose(skin, np.random.default_rng(0), "sitting")


def test_other_models_are_not_posed():
    repo = Path(__file__).resolve().parents[2]
    assert not posable(str(repo / "assets/models/openmaterial_human/human_example.gltf"))
    assert not posable(str(repo / "assets/models/kenney_vehicles/vehicle-truck-red.glb"))


# ---------------------------------------------------------------------- clothes' colours
def test_people_clothes_are_recoloured_and_skin_is_not():
    path, _ = _first()
    model, _ = posed_model(path, SIZE, "+y", "+z", np.random.default_rng(3))
    look = draw_appearance(model, "person", np.random.default_rng(0))
    keys = np.array([k for k, _ in look.recolour])
    by_name = {p.name: p.colors[0] for p in model.parts}

    def recoloured(name):  # lit.glsl: a vertex colour within 1e-3 of a key takes its new colour
        return bool((np.abs(keys - by_name[name]).max(1) < 1e-3).any())

    assert len(keys) == 3 and all(recoloured(n) for n in ("clothes_top", "clothes_bottom", "shoes"))
    assert not any(recoloured(n) for n in ("skin", "hair", "eyes", "eyebrows"))
    assert len(look.names) == 3 and look.to_dict()["clothes"] == list(look.names)


# ---------------------------------------------------------------------- the renderer's cache
@pytest.mark.slow
def test_renderer_keeps_a_bounded_number_of_models(gl_clean):
    from synthcompose.render import Lighting, Renderer, RenderObject
    from synthcompose.render.renderer import MODELS_KEPT

    from ..helpers import make_camera

    path, _ = _first()
    renderer = Renderer(gl_clean)
    pose = np.eye(4)
    pose[:3, 3] = (12.0, 0.0, 0.0)
    light = Lighting.daylight(elevation_deg=40.0, azimuth_deg=150.0, sun_fraction=0.5)
    owned = None
    for seed in range(MODELS_KEPT + 6):
        model, _ = posed_model(path, SIZE, "+y", "+z", np.random.default_rng(seed))
        passes = renderer.render(make_camera(), [RenderObject(model, pose, (0.2, 0.2, 0.2))], light)
        renderer.release(passes)
        assert renderer.models_kept <= MODELS_KEPT + 1
        if seed == MODELS_KEPT:
            owned = len(gl_clean._owned)
    assert len(gl_clean._owned) <= owned  # GL objects of the dropped models are freed
    assert isinstance(model, Model)


# ---------------------------------------------------------------------- in a batch
def test_batch_poses_each_person_and_records_the_pose(tmp_path):
    from synthcompose.cli import main
    from synthcompose.synthetic import make_sample

    from ..helpers import H, W

    root = tmp_path / "cityscapes"
    make_sample(root, count=2, width=W, height=H, seed=1)
    objects = []
    for entry in ENTRIES[:4]:
        e = json.loads(entry.read_text())
        objects.append({"name": e["id"], "model": str(entry.parent / e["model"]), "class": "person",
                        "size": e["size"], "up": e["up"], "forward": e["forward"]})
    manifest = tmp_path / "m.json"
    manifest.write_text(json.dumps({"dataset": str(root), "output": str(tmp_path / "out"), "seed": 4,
                                    "objects_per_image": 3, "objects": objects}))
    assert main(["batch", str(manifest), "--no-progress"]) == 0
    poses = [o["appearance"]["pose"] for rec in sorted((tmp_path / "out" / "synthcompose").rglob("*.json"))
             for o in json.loads(rec.read_text())["objects"]]
    assert len(poses) >= 2 and len({p["pose_id"] for p in poses}) == len(poses)
    assert all(p["pose"] in ("standing", "walking") for p in poses)
