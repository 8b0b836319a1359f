import numpy as np
import pytest

from flexhrc.errors import FormatError
from flexhrc.perception.scene import (
    CameraIntrinsics,
    DetectedObject,
    ObjectSink,
    RuleSet,
    ScenePerception,
    Tracker,
    depth_to_cloud,
    generate_scene,
    publish_objects,
    render_depth,
)
from flexhrc.perception.scene.bench import match, run_bench
from flexhrc.perception.scene.primitives import fit_box, fit_cone, fit_cylinder, fit_sphere, pca
from flexhrc.perception.scene.segmentation import euclidean_clusters, ransac_plane


def test_depth_to_cloud_pinhole():
    intr = CameraIntrinsics(100.0, 100.0, 1.0, 1.0, 3, 3)
    depth = np.full((3, 3), 2.0)
    depth[0, 0] = 0.0  # no return
    cloud = depth_to_cloud(depth, intr)
    assert cloud.shape == (8, 3)
    assert np.allclose(cloud[:, 2], 2.0)
    # Pixel (u=2, v=1) is 1 px right of the centre: x = 1 * 2 / 100.
    assert any(np.allclose(p, [0.02, 0.0, 2.0]) for p in cloud)
    T = np.eye(4)
    T[:3, 3] = [1, 2, 3]
    assert np.allclose(depth_to_cloud(depth, intr, T), cloud + np.array([1.0, 2.0, 3.0]))
    with pytest.raises(ValueError, match="intrinsics say"):
        depth_to_cloud(np.ones((2, 2)), intr)


def test_clusters():
    rng = np.random.default_rng(0)
    a = rng.uniform(0, 0.05, (300, 3))
    b = rng.uniform(0, 0.05, (200, 3)) + np.array([0.5, 0.0, 0.0])
    pts = np.vstack([a, b])
    clusters = euclidean_clusters(pts, 0.03)
    assert sorted(len(c) for c in clusters) == [200, 300]
    assert len(euclidean_clusters(pts, 0.03, min_points=10**6)) == 0


def test_ransac_plane_finds_the_table():
    rng = np.random.default_rng(1)
    table = np.column_stack([rng.uniform(-1, 1, 5000), rng.uniform(-1, 1, 5000), np.zeros(5000)])
    clutter = rng.uniform(0.05, 0.3, (1000, 3))
    n, d, inl = ransac_plane(np.vstack([table, clutter]) + rng.normal(0, 0.002, (6000, 3)))
    assert abs(abs(n[2]) - 1) < 1e-3 and abs(d) < 2e-3
    assert inl[:5000].mean() > 0.99 and inl[5000:].mean() < 0.05


def _cylinder_points(rng, length=0.4, r=0.03, n=1500, noise=0.001):
    # Upper half of a cylinder lying along x at height r (what a camera above sees).
    s = rng.uniform(-length / 2, length / 2, n)
    a = rng.uniform(0, np.pi, n)
    p = np.column_stack([s, r * np.cos(a), r + r * np.sin(a)])
    return p + rng.normal(0, noise, p.shape)


def test_primitive_fits_recover_shapes():
    rng = np.random.default_rng(2)
    cyl = fit_cylinder(_cylinder_points(rng), tol=0.004, rng=rng)
    assert cyl.size[0] == pytest.approx(0.4, abs=0.01)
    assert cyl.params["radius"] == pytest.approx(0.03, abs=0.003)
    assert np.allclose(cyl.center, [0, 0, 0.03], atol=0.005)
    assert abs(cyl.axis[0]) > 0.99
    # Sphere cap.
    u = rng.normal(size=(1500, 3))
    u[:, 2] = np.abs(u[:, 2])
    u /= np.linalg.norm(u, axis=1, keepdims=True)
    sph = fit_sphere(0.05 * u + [0.1, 0.2, 0.05], tol=0.003, rng=rng)
    assert sph.params["radius"] == pytest.approx(0.05, abs=0.003)
    assert np.allclose(sph.center, [0.1, 0.2, 0.05], atol=0.004)
    assert sph.inlier_ratio > 0.9
    # Top face of a flat board, rotated by 30 degrees.
    top = np.column_stack([rng.uniform(-0.3, 0.3, 3000), rng.uniform(-0.2, 0.2, 3000),
                           np.full(3000, 0.03)])  # fmt: skip
    c, s = np.cos(0.5), np.sin(0.5)
    top[:, :2] = top[:, :2] @ np.array([[c, s], [-s, c]])
    box = fit_box(top, tol=0.004)
    assert np.allclose(box.size, [0.6, 0.4, 0.03], atol=0.01)
    assert abs(abs(box.axis[:2] @ [c, s]) - 1) < 1e-3
    # Upright cone, one side visible.
    h, r = 0.1, 0.04
    z = rng.uniform(0, h, 2000)
    ang = rng.uniform(-np.pi / 2, np.pi / 2, 2000)
    rad = r * (1 - z / h)
    cone_pts = np.column_stack([rad * np.cos(ang) + 0.3, rad * np.sin(ang) + 0.1, z])
    cone = fit_cone(cone_pts, tol=0.003, rng=rng)
    assert cone.params["height"] == pytest.approx(h, abs=0.01)
    assert cone.params["radius"] == pytest.approx(r, abs=0.005)
    _, axes, var = pca(_cylinder_points(rng))
    assert abs(axes[0][0]) > 0.99 and var[0] > var[1] >= var[2]


def test_rules_are_data_and_validated(tmp_path):
    rules = RuleSet.default()
    assert rules.classify("cylinder", np.array([0.30, 0.05, 0.05]))[0] == "leg_short"
    assert rules.classify("cylinder", np.array([0.45, 0.05, 0.05]))[0] == "leg_long"
    assert rules.classify("cylinder", np.array([0.38, 0.05, 0.05]))[0] == "unknown"
    assert rules.classify("sphere", np.array([0.30, 0.05, 0.05]))[0] == "unknown"
    f = tmp_path / "rules.yaml"
    f.write_text(
        "- type: leg\n  primitive: cylinder\n  size: [0.3, 0.05, 0.05]\n  tolerance: 0.1\n"
    )
    assert RuleSet.load(f).classify("cylinder", np.array([0.38, 0.05, 0.05]))[0] == "leg"
    f.write_text("- type: x\n  primitive: torus\n  size: [1, 1, 1]\n  tolerance: 1\n")
    with pytest.raises(FormatError, match="rule 1: unknown primitive 'torus'"):
        RuleSet.load(f)
    f.write_text("- type: x\n  primitive: box\n")
    with pytest.raises(FormatError, match="missing size, tolerance"):
        RuleSet.load(f)
    with pytest.raises(FormatError, match="non-empty list"):
        RuleSet.from_data([])


def test_pipeline_on_generated_scenes():
    rng = np.random.default_rng(7)
    perception = ScenePerception()
    for _ in range(3):
        scene = generate_scene(rng)
        depth = render_depth(scene, noise=0.002, rng=rng)
        objs = perception.process_depth(depth, scene.intrinsics, scene.extrinsics)
        truth = np.array([o.center for o in scene.objects])
        pairs = match(truth, np.array([o.position for o in objs]), 0.05)
        assert len(pairs) == len(scene.objects) == len(objs)
        for ti, di in pairs:
            assert objs[di].type == scene.objects[ti].type
            assert np.linalg.norm(objs[di].position - truth[ti]) < 0.01
            assert np.isclose(np.linalg.norm(objs[di].orientation), 1.0)


def test_empty_and_bad_clouds():
    p = ScenePerception()
    assert p.process(np.zeros((10, 3))) == []
    with pytest.raises(ValueError, match=r"\(n, 3\)"):
        p.process(np.zeros((10, 2)))
    with pytest.raises(ValueError):
        ScenePerception(cluster_radius=0)


def _obj(i, pos, t="leg_short"):
    quat, axis, size = np.array([0, 0, 0, 1.0]), np.array([1.0, 0, 0]), np.array([0.3, 0.05, 0.05])
    return DetectedObject(f"c{i}", t, np.asarray(pos, float), quat, axis, size, 0.9, "cylinder")


def test_tracker_keeps_identities():
    tr = Tracker(max_distance=0.05, max_missed=1)
    f1 = tr.update([_obj(0, [0, 0, 0]), _obj(1, [0.5, 0, 0])])
    ids = {o.id for o in f1}
    assert ids == {"obj_1", "obj_2"}
    # Next frame: order swapped, small motion, one new object.
    f2 = tr.update([_obj(0, [0.51, 0.01, 0]), _obj(1, [0.01, 0, 0]), _obj(2, [1, 1, 0])])
    assert [o.id for o in f2] == ["obj_2", "obj_1", "obj_3"]
    tr.update([])
    tr.update([])  # missed twice > max_missed: tracks end
    assert tr.tracks == {}
    assert tr.update([_obj(0, [0, 0, 0])])[0].id == "obj_4"


def test_tracking_through_a_generated_sequence():
    """The same scene perceived over frames with small object motion keeps every id."""
    rng = np.random.default_rng(3)
    scene = generate_scene(rng)
    perception, tracker = ScenePerception(), Tracker()
    first = None
    for k in range(3):
        for i, o in enumerate(scene.objects):  # everything slides 5 mm per frame
            moved = o.center + np.array([0.005, 0.0, 0.0])
            scene.objects[i] = type(o)(o.type, o.primitive, moved, o.yaw, o.dims)
        depth = render_depth(scene, noise=0.002, rng=rng)
        objs = tracker.update(perception.process_depth(depth, scene.intrinsics, scene.extrinsics))
        ids = {o.id: o.type for o in objs}
        first = first or ids
        assert ids == first, f"frame {k}"


class FakeKnowledgeBase:
    """Dict-backed stand-in for flexhrc.knowledge (implements ObjectSink)."""

    def __init__(self):
        self.objects: dict[str, dict] = {}

    def update_object(self, obj_id, type, pose, size, **attrs):
        self.objects[obj_id] = {"type": type, "pose": pose, "size": size, **attrs}


def test_knowledge_base_hook():
    kb = FakeKnowledgeBase()
    assert isinstance(kb, ObjectSink)
    n = publish_objects(kb, [_obj(0, [0.1, 0.2, 0.03]), _obj(1, [0.4, 0, 0.03], "leg_long")])
    assert n == 2
    assert kb.objects["c0"]["pose"] == (0.1, 0.2, 0.03, 0.0, 0.0, 0.0, 1.0)
    assert kb.objects["c1"]["type"] == "leg_long"
    assert kb.objects["c1"]["size"] == (0.3, 0.05, 0.05)
    assert kb.objects["c1"]["primitive"] == "cylinder"
    assert _obj(0, [0, 0, 0]).to_dict()["type"] == "leg_short"


def test_bench_small():
    res = run_bench(n_scenes=2, seed=1, noise=0.002, width=200, height=150)
    for key in ("detection_rate", "position_error_m", "size_error_rel", "type_accuracy", "frame_s"):
        assert key in res
    assert res["detection_rate"] >= 0.9
    with pytest.raises(ValueError):
        run_bench(n_scenes=0)


def test_pybullet_rendering_matches_the_ray_caster():
    pytest.importorskip("pybullet")
    from flexhrc.perception.scene.sim_render import render_depth_pybullet

    rng = np.random.default_rng(5)
    scene = generate_scene(rng)
    d_pb = render_depth_pybullet(scene)
    d_rc = render_depth(scene)
    both = (d_pb > 0) & (d_rc > 0)
    assert both.mean() > 0.8
    assert np.median(np.abs(d_pb - d_rc)[both]) < 0.002
    objs = ScenePerception().process_depth(d_pb, scene.intrinsics, scene.extrinsics)
    pairs = match(
        np.array([o.center for o in scene.objects]), np.array([o.position for o in objs]), 0.05
    )
    assert len(pairs) == len(scene.objects)
    assert all(objs[d].type == scene.objects[t].type for t, d in pairs)
