"""Support surfaces (floor, seat) found in scans and left out of the fit."""

from __future__ import annotations

import numpy as np
import pytest

from dressmeup.body.registration.support import find_supports, remove_support, support_mask
from dressmeup.errors import InputError


def _face(rng, origin, a, b, n_per_m2=10000):
    """Uniform points on the parallelogram origin + s a + t b, s, t in [0, 1]."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    k = int(n_per_m2 * np.linalg.norm(np.cross(a, b)))
    s, t = rng.uniform(size=(2, k, 1))
    return np.asarray(origin, float) + s * a + t * b


def _box(rng, lo=(-0.25, 0.0, -0.25), size=(0.5, 0.45, 0.5)):
    """Top and four sides of a box (a seat from the floor), (k, 3) points."""
    x, y, z = size
    o = np.asarray(lo, float)
    return np.vstack([
        _face(rng, o + (0, y, 0), (x, 0, 0), (0, 0, z)),
        _face(rng, o, (x, 0, 0), (0, y, 0)), _face(rng, o + (0, 0, z), (x, 0, 0), (0, y, 0)),
        _face(rng, o, (0, 0, z), (0, y, 0)), _face(rng, o + (x, 0, 0), (0, 0, z), (0, y, 0)),
    ])


def _sphere(rng, centre, radius, n_per_m2=10000):
    k = int(n_per_m2 * 4 * np.pi * radius ** 2)
    d = rng.normal(size=(k, 3))
    return np.asarray(centre) + radius * d / np.linalg.norm(d, axis=1, keepdims=True)


def _cylinder(rng, centre, radius, length, n_per_m2=10000):
    """Side of a horizontal cylinder along x."""
    k = int(n_per_m2 * 2 * np.pi * radius * length)
    a = rng.uniform(0, 2 * np.pi, k)
    x = rng.uniform(-length / 2, length / 2, k)
    return np.asarray(centre) + np.c_[x, radius * np.cos(a), radius * np.sin(a)]


def test_box_planes_found_curved_shapes_kept():
    """A seat box with a ball and a thigh-like cylinder beside it: the five faces are found
    (one horizontal, four vertical) and all box points go; no curved point does."""
    rng = np.random.default_rng(0)
    box = _box(rng)
    ball = _sphere(rng, (0.0, 0.75, 0.0), 0.15)          # 15 cm above the top
    thigh = _cylinder(rng, (0.0, 0.3, 0.55), 0.08, 0.5)  # 22 cm in front of the box
    P = np.vstack([box, ball, thigh]) + rng.normal(0, 0.002, (len(box) + len(ball)
                                                              + len(thigh), 3))
    planes = find_supports(P, seed=0)
    kinds = sorted(p.summary()["kind"] for p in planes)
    assert kinds == ["horizontal"] + ["vertical"] * 4
    on = support_mask(P, planes)
    nb = len(box)
    assert on[:nb].mean() > 0.995
    assert on[nb:].sum() == 0
    top = next(p for p in planes if p.summary()["kind"] == "horizontal")
    assert abs(abs(top.normal[1]) - 1) < 1e-3 and abs(abs(top.offset) - 0.45) < 2e-3
    kept, planes2 = remove_support(P, seed=0)
    assert len(kept) == len(P) - on.sum() and len(planes2) == 5


def test_a_ball_on_the_seat_loses_only_its_contact_cap():
    """A ball resting on the top: only its points within the 8 mm band over the top go
    (a cap of height 8 mm: 2 pi R h = 2.7 % of a 15 cm ball's area), and the top stays."""
    rng = np.random.default_rng(1)
    box = _box(rng)
    ball = _sphere(rng, (0.0, 0.45 + 0.15, 0.0), 0.15)
    P = np.vstack([box, ball])
    on = support_mask(P, find_supports(P, seed=1))
    assert on[:len(box)].mean() > 0.995
    lost = on[len(box):].mean()
    assert 0 < lost <= 0.008 / (2 * 0.15) + 0.005


def test_scan_without_support_keeps_the_person_of_a_mesh_and_of_points():
    """A mesh of a seat box (top and sides, subdivided, all 5 found as supports) with a ball
    on it: the box's faces and vertices go (but for a few at its corners, outside the
    regions), the ball stays whole; points lose exactly the masked ones; no planes: the scan
    itself comes back."""
    import trimesh

    from dressmeup.body.registration.support import scan_without_support

    box = trimesh.creation.box(extents=(0.5, 0.45, 0.5)).subdivide_to_size(0.02)
    box.apply_translation((0.0, 0.225, 0.0))
    box.update_faces(~(box.vertices[box.faces][:, :, 1] < 1e-6).all(1))  # no bottom
    box.remove_unreferenced_vertices()
    ball = trimesh.creation.icosphere(subdivisions=3, radius=0.15)
    ball.apply_translation((0.0, 0.45 + 0.16, 0.0))
    mesh = trimesh.util.concatenate([box, ball])
    rng = np.random.default_rng(2)
    planes = find_supports(np.vstack([_box(rng), _sphere(rng, (0, 0.61, 0), 0.15)]), seed=2)
    assert len(planes) == 5
    V, F = scan_without_support(mesh, planes)
    on_ball = np.abs(np.linalg.norm(V - (0, 0.61, 0), axis=1) - 0.15) < 1e-6
    assert on_ball.sum() == len(ball.vertices)  # the ball whole
    ball_faces = on_ball[F].all(1)
    assert ball_faces.sum() == len(ball.faces)
    assert (~ball_faces).sum() < 0.01 * len(box.faces)  # the box's corners at most
    assert F.min() == 0 and F.max() == len(V) - 1 and len(np.unique(F)) == len(V)
    P = np.asarray(mesh.vertices)
    assert len(scan_without_support(P, planes)) == len(P) - support_mask(P, planes).sum()
    assert scan_without_support(mesh, []) is mesh


def test_flat_square_threshold_and_torso_curvature():
    """Geometry of the acceptance test (defaults: a 30 cm square flat within +-8 mm).

    A flat 35 cm square qualifies, a 25 cm one does not. A torso-like cylinder of radius
    15 cm (sagitta over a 30 cm chord: 30^2 / (8 * 15) = 7.5 cm) does not, and nor does a
    broad one of radius 40 cm (2.8 cm), taller than the square; a floor of 1.5 m does.
    """
    rng = np.random.default_rng(2)
    small = _face(rng, (0, 0, 0), (0.25, 0, 0), (0, 0, 0.25))
    large = _face(rng, (1, 0, 0), (0.35, 0, 0), (0, 0, 0.35))
    torso = np.vstack([_cylinder(rng, (0, 1, 1), 0.15, 0.6), _cylinder(rng, (0, 1, 2), 0.4, 0.6)])
    noise = rng.normal(0, 0.002, (len(small) + len(large) + len(torso), 3))
    P = np.vstack([small, large, torso]) + noise
    on = support_mask(P, find_supports(P, seed=2))
    n1, n2 = len(small), len(small) + len(large)
    assert on[:n1].sum() == 0 and on[n1:n2].mean() > 0.99 and on[n2:].sum() == 0
    floor = _face(rng, (-0.75, -0.9, -0.75), (1.5, 0, 0), (0, 0, 1.5))
    assert len(find_supports(np.vstack([floor, torso]), seed=2)) == 1


@pytest.mark.parametrize("name", ["procedural", pytest.param("anny", marks=pytest.mark.slow)])
def test_body_scans_lose_only_what_touches_a_support(name):
    """Body scans (standing, sitting) without a seat: no point is a support. With the seat
    box and a floor, box and floor go (two horizontal planes, four sides) and of the body
    only points touching them: within the 8 mm band of the floor or the box."""
    from scipy.spatial import cKDTree

    from dressmeup.body import BodyParams, get_body_model
    from dressmeup.body.synthetic import named_pose, synthetic_scan

    model = get_body_model(name)
    for i, pose in enumerate(("standing", "sitting")):
        truth = BodyParams(name, shape=np.full(model.shape_dim, 0.5), pose=named_pose(pose))
        body = synthetic_scan(model, truth, n_points=8000, noise=0.002, seed=i)
        assert support_mask(body, find_supports(body, seed=i)).sum() == 0
    body = synthetic_scan(model, truth, n_points=8000, noise=0.0, seed=1)
    both = synthetic_scan(model, truth, n_points=8000, noise=0.0, seed=1, seat_box=True,
                          floor=0.3)
    planes = find_supports(both, seed=1)
    on = support_mask(both, planes)
    extra = both[len(body):]
    assert np.allclose(extra[extra[:, 1] < extra[:, 1].min() + 1e-9, 1],
                       model.posed(truth).vertices[:, 1].min())  # the floor at the soles
    assert on[len(body):].mean() > 0.99
    lost = body[on[:len(body)]]
    assert len(lost) < 0.03 * len(body)
    if len(lost):  # the support surfaces are sampled ~1 cm apart
        assert cKDTree(extra).query(lost)[0].max() < 0.008 + 0.02
    kinds = sorted(p.summary()["kind"] for p in planes)
    assert kinds == ["horizontal"] * 2 + ["vertical"] * 4


def test_registrar_leaves_the_seat_out_and_reports_it():
    from dressmeup.body import BodyParams, get_body_model
    from dressmeup.body.registration import register
    from dressmeup.body.synthetic import named_pose, synthetic_scan

    model = get_body_model("procedural")
    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=named_pose("sitting"))
    scan = synthetic_scan(model, truth, n_points=6000, noise=0.002, seed=3, seat_box=True)
    fast = dict(iterations=(1, 1, 1), n_scan_points=2000, verbose=False, hypotheses=(),
                limb_search=False, shape_search=False)
    res = register(scan, model, return_result=True, **fast)
    info = res.info["support"]
    assert info["points_removed"] > 0 and info["points_checked"] == min(8000, len(scan))
    assert "horizontal" in [p["kind"] for p in info["planes"]] and len(res.supports) >= 2
    assert "support" not in register(scan, model, return_result=True, remove_support=False,
                                     **fast).info
    floor_only = _face(np.random.default_rng(4), (-0.5, 0, -0.5), (1, 0, 0), (0, 0, 1))
    with pytest.raises(InputError, match="flat surfaces.*keep-support"):
        register(floor_only, model, **fast)


def test_keypoints_are_detected_on_the_scan_without_the_seat(monkeypatch):
    """The keypoint route renders the scan the fit sees: the seat's points are not drawn."""
    import dressmeup.body.registration.keypoints as kp
    from dressmeup.body import BodyParams, get_body_model
    from dressmeup.body.registration import register
    from dressmeup.body.synthetic import named_pose, synthetic_scan

    model = get_body_model("procedural")
    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=named_pose("sitting"))
    scan = synthetic_scan(model, truth, n_points=6000, noise=0.002, seed=3, seat_box=True)
    seen = []

    def detect(points, model):
        seen.append(np.asarray(points))
        return kp.ScanKeypoints(joints=np.full((model.n_joints, 3), np.nan), views=8,
                                detections=0, inliers={})

    import dressmeup.body.registration.optimizer as opt

    for mod in (kp, opt):   # the optimizer binds both names when imported
        monkeypatch.setattr(mod, "keypoints_available", lambda: True)
        monkeypatch.setattr(mod, "detect_keypoints", detect)
    res = register(scan, model, return_result=True, init_route="keypoints", iterations=(1, 1, 1),
                   n_scan_points=2000, verbose=False, hypotheses=(), limb_search=False,
                   shape_search=False)
    assert len(seen) == 1 and res.supports
    from dressmeup.body.registration.support import support_mask

    assert len(seen[0]) < len(scan) and not support_mask(seen[0], res.supports).any()


def test_register_command_measures_the_fit_without_the_support(tmp_path, capsys, monkeypatch):
    """``dressmeup register`` says what it left out and measures scan -> body without the
    seat (with it, the box's points would be 10-40 cm from the body); ``--keep-support``
    turns the removal off. The fit itself is stubbed with the true body."""
    import json

    import dressmeup.body.registration as registration
    from dressmeup.body import BodyParams, get_body_model
    from dressmeup.body.registration import RegistrationResult
    from dressmeup.body.synthetic import named_pose, synthetic_scan
    from dressmeup.cli import main

    model = get_body_model("procedural")
    truth = BodyParams("procedural", shape=np.full(6, 0.5), pose=named_pose("sitting"))
    scan = synthetic_scan(model, truth, n_points=6000, noise=0.002, seed=3, seat_box=True)
    np.save(tmp_path / "scan.npy", scan)
    seen = {}

    def fit(scan, model, init=None, keypoints=None, registrar="optimization",
            return_result=False, **options):
        seen.update(options)
        if not options["remove_support"]:
            return RegistrationResult(params=truth, seconds=0.0)
        kept, planes = remove_support(scan)
        info = {"points_removed": len(scan) - len(kept), "points_checked": len(scan),
                "planes": [p.summary() for p in planes]}
        return RegistrationResult(params=truth, seconds=0.0, info={"support": info},
                                  supports=planes)

    monkeypatch.setattr(registration, "register", fit)
    out = tmp_path / "body.npz"
    args = ["register", str(tmp_path / "scan.npy"), "--model", "procedural", "--out", str(out),
            "--no-picture"]
    assert main(args) == 0 and seen["remove_support"] is True
    assert "flat support surfaces (horizontal, vertical" in capsys.readouterr().out
    without = json.loads((tmp_path / "body.metrics.json").read_text())["scan_to_body_mm"]
    assert main(args + ["--keep-support"]) == 0 and seen["remove_support"] is False
    assert "support" not in capsys.readouterr().out
    kept = json.loads((tmp_path / "body.metrics.json").read_text())["scan_to_body_mm"]
    assert without < 10 < kept
