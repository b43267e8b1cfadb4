"""Generator 4's motion and cloth dynamics, on analytic cases: backward Euler's free fall,
cloth resting on and lifted by a moving box (no penetration, the barrier's gap), two layers
kept apart, and the motion's frames."""

import numpy as np
import pytest
import trimesh

from dressmeup.data.synth.dynamics import ClothDynamics, DynamicsSettings, simulate
from dressmeup.data.synth.motion import MotionSpec, body_states, frame_bodies, smoothstep
from dressmeup.errors import InputError

UP = np.array([0.0, 0.0, 1.0])


def _sheet(n=6, size=0.1, z=0.0, offset=(0.0, 0.0)):
    """A flat square sheet ``(V, F)`` of ``n x n`` vertices in the plane ``z``."""
    t = np.linspace(-size / 2, size / 2, n)
    X, Y = np.meshgrid(t, t, indexing="ij")
    V = np.stack([X.ravel() + offset[0], Y.ravel() + offset[1], np.full(n * n, z)], 1)
    F = []
    for i in range(n - 1):
        for j in range(n - 1):
            a, b, c, d = i * n + j, (i + 1) * n + j, (i + 1) * n + j + 1, i * n + j + 1
            F += [[a, b, c], [a, c, d]]
    return V, np.array(F, np.int64)


def _box(top=0.0, size=0.3):
    """A closed box ``(V, F)`` whose top face is at height ``top``."""
    box = trimesh.creation.box(extents=(size, size, 0.1))
    V = np.asarray(box.vertices, np.float64) + [0.0, 0.0, top - 0.05]
    return V, np.asarray(box.faces, np.int64)


def test_free_fall_follows_backward_euler_with_damping():
    V, F = _sheet()
    body_V, body_F = _box(top=-5.0)  # far below: no contact
    s = DynamicsSettings(damping=2.0)
    dyn = ClothDynamics(V, F, body_F, UP, s)
    h, frames = 1.0 / 30.0, 12
    x, stats = simulate(dyn, V, [body_V] * (frames + 1), h)
    # rigid translation keeps every spring at rest: v' = (v - g h) / (1 + gamma h)
    v, z = 0.0, 0.0
    for _ in range(frames):
        v = (v - s.gravity * h) / (1.0 + s.damping * h)
        z += h * v
    np.testing.assert_allclose(x[:, 2], z, rtol=1e-6)
    np.testing.assert_allclose(x[:, :2], V[:, :2], atol=1e-9)
    assert stats["unconverged_frames"] == 0 and stats["frames"] == frames


def test_a_motion_over_the_substep_budget_fails_at_the_frame_that_goes_over():
    V, F = _sheet()
    body_V, body_F = _box(top=-5.0)  # no contact: one sub-step a frame
    bodies = [body_V] * 9
    _, stats = simulate(ClothDynamics(V, F, body_F, UP, DynamicsSettings(substep_budget=1.0)),
                        V, bodies, 1.0 / 30.0)
    assert stats["substeps"] == 8  # exactly at the budget: allowed
    dyn = ClothDynamics(V, F, body_F, UP, DynamicsSettings(substep_budget=0.5))
    with pytest.raises(RuntimeError, match=r"frame 5 of 8: 5 sub-steps, over the budget of 4 "):
        simulate(dyn, V, bodies, 1.0 / 30.0)


def test_a_frame_stops_at_the_substep_over_its_limit_before_solving_it():
    from dressmeup.data.synth.dynamics import SubstepsExceeded

    V, F = _sheet()
    body_V, body_F = _box(top=-5.0)
    dyn = ClothDynamics(V, F, body_F, UP, DynamicsSettings())
    calls = []
    dyn.solve_step = lambda *a, **k: calls.append(1)  # never reached
    with pytest.raises(SubstepsExceeded) as over:
        dyn.advance(V, np.zeros_like(V), 1.0 / 30.0, body_V, body_V, substep_limit=0)
    assert over.value.substeps == 1 and not calls


def test_cloth_rests_on_a_box_outside_it_within_the_barrier_gap():
    V, F = _sheet(z=0.02)
    body_V, body_F = _box(top=0.0)
    s = DynamicsSettings()
    dyn = ClothDynamics(V, F, body_F, UP, s)
    x, stats = simulate(dyn, V, [body_V] * 31, 1.0 / 30.0)
    assert dyn.intersection_free(x, body_V)
    assert x[:, 2].min() > 0.0  # above the top face: never inside
    assert x[:, 2].max() < s.dhat  # and resting within the barrier's reach
    assert stats["unconverged_frames"] == 0


def test_a_rising_box_lifts_the_cloth_without_penetration():
    V, F = _sheet(z=0.002)
    body_V, body_F = _box(top=0.0)
    # the box rises 6 cm in 6 frames (1 cm a frame, more than three barrier gaps)
    bodies = [body_V + [0.0, 0.0, 0.01 * k] for k in range(7)]
    dyn = ClothDynamics(V, F, body_F, UP, DynamicsSettings())
    seen = []
    x, _ = simulate(dyn, V, bodies, 1.0 / 30.0,
                    on_frame=lambda k, x, st: seen.append(x[:, 2].min() - 0.01 * k))
    assert min(seen) > 0.0  # every frame: the whole sheet above the moving top face
    assert dyn.intersection_free(x, bodies[-1])
    assert x[:, 2].min() > 0.06


def test_two_layers_stay_apart():
    a_V, a_F = _sheet(n=5, size=0.08, z=0.004)
    b_V, b_F = _sheet(n=5, size=0.08, z=0.012, offset=(0.004, 0.003))
    V = np.vstack([a_V, b_V])
    F = np.vstack([a_F, b_F + len(a_V)])
    body_V, body_F = _box(top=0.0)
    dyn = ClothDynamics(V, F, body_F, UP, DynamicsSettings())
    x, _ = simulate(dyn, V, [body_V] * 25, 1.0 / 30.0)
    assert dyn.intersection_free(x, body_V)
    lower, upper = x[: len(a_V), 2], x[len(a_V):, 2]
    assert lower.min() > 0.0
    assert upper.min() > lower.max() - 1e-9  # the upper sheet still lies on the lower one


def test_motion_frames_phases_and_end_points():
    spec = MotionSpec(dt=0.05, rest_frames=2, shape_frames=3, pose_frames=4, settle_frames=1)
    a, b = np.zeros(2), np.array([1.0, -1.0])
    q = np.full((3, 3), 0.5)
    st = body_states(spec, a, b, q)
    assert len(st) == spec.frames + 1 == 11
    assert [s.phase for s in st] == (["start"] + ["rest"] * 2 + ["shape"] * 3 + ["pose"] * 4
                                     + ["settle"])
    np.testing.assert_array_equal(st[0].shape, a)
    np.testing.assert_array_equal(st[5].shape, b)
    np.testing.assert_array_equal(st[-1].pose, q)
    np.testing.assert_array_equal(st[5].pose, 0 * q)
    # each joint turns about its own fixed axis, at the smoothstep's pace
    np.testing.assert_allclose(st[7].pose, smoothstep(2 / 4) * q)
    assert spec.duration == pytest.approx(0.5)
    fine = spec.refined(2)
    assert fine.duration == pytest.approx(spec.duration) and fine.frames == 2 * spec.frames
    calls = []
    bodies = frame_bodies(st, lambda s, p: calls.append(1) or np.full((4, 3), s.sum() + p.sum()))
    assert len(bodies) == len(st)
    assert len(calls) == 1 + 3 + 4  # frames where the body holds still share one array


def test_smoothstep_starts_and_stops_at_rest():
    eps = 1e-6
    assert smoothstep(0) == 0 and smoothstep(1) == 1 and smoothstep(0.5) == 0.5
    assert (smoothstep(eps) - smoothstep(0)) / eps < 1e-5
    assert (smoothstep(1) - smoothstep(1 - eps)) / eps < 1e-5
    t = np.linspace(0, 1, 50)
    assert np.all(np.diff([smoothstep(v) for v in t]) > 0)


@pytest.mark.parametrize("bad", [{"dt": 0.0}, {"dt": float("nan")}, {"pose_frames": 0},
                                 {"rest_frames": -1}, {"shape_frames": 2.5}, {"frames": 3}])
def test_motion_settings_are_checked(bad):
    with pytest.raises(InputError, match="motion"):
        MotionSpec.from_dict(bad)


def test_pinched_faces_are_those_of_parts_pressed_together():
    """Two plates 8 cm apart at rest, pressed to 5 mm: the facing vertices are pinched;
    a plate's own neighbours (close at rest) never are."""
    from dressmeup.data.synth.dynamics import pinched

    A, FA = _sheet(n=5, size=0.04, z=0.0)
    B, FB = _sheet(n=5, size=0.04, z=0.08)
    rest = np.vstack([A, B])
    F = np.vstack([FA, FB + len(A)])
    keep = np.ones(len(F), bool)
    assert not pinched(F, keep, [rest], rest, 0.01, 0.05).any()
    pressed = np.vstack([A, B - [0.0, 0.0, 0.075]])
    assert pinched(F, keep, [rest, pressed], rest, 0.01, 0.05).all()
    # apart in one of the frame's bodies only is enough; beyond the pinch distance is not
    assert not pinched(F, keep, [np.vstack([A, B - [0.0, 0.0, 0.065]])], rest, 0.01, 0.05).any()


def test_blended_carry_keeps_a_uniform_move_and_averages_close_layers():
    V, _ = _sheet(n=4, size=0.03, z=0.0)
    W, _ = _sheet(n=4, size=0.03, z=0.01)  # a second layer 1 cm above
    x = np.vstack([V, W])
    uniform = np.tile([0.01, 0.0, 0.0], (len(x), 1))
    assert np.allclose(ClothDynamics._blended(x, uniform, 0.06), uniform)
    u = np.zeros_like(x)
    u[len(V):] = [0.0, 0.0, -0.02]  # only the upper layer carried down
    out = ClothDynamics._blended(x, u, 0.06)
    # both layers now move alike (within a few per cent): the upper one no longer runs
    # into the lower one
    assert np.all(out[:, 2] < 0)
    assert np.ptp(out[:, 2]) < 0.25 * 0.02
