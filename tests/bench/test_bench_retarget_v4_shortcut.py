"""No shortcut to the v4 ground truth: public files + the generator's operators, on tiny v4.

The v4 ground truth is made by simulation from each garment's design body at rest
(generator 3.0.0); the public part of ``synth-retarget-tiny-v4`` holds, of the scored split,
only the source samples' garments and every sample's body. A participant could still apply
the toolkit's own generator operators to public files. Each such shortcut below must land no
closer to the ground truth (mean P2S over the edition's pairs) than the best reference method
scored the same way (the ``rigid``, ``skinning`` and ``transfer`` baselines; ``transfer`` is
itself the generator-2.x operator that carries the source garment by the body's displacement
at its closest point, :func:`dressmeup.data.synth.generator2.transfer_to_body`: this test found
it closer than ``skinning`` on tiny v4, so it became a reference method):

- the source garment unchanged;
- the ``transfer`` start relaxed by generator 2.1.0's quasi-static solver on the target body
  (:func:`dressmeup.data.synth.drape.drape`, the source garment's edge lengths as rest
  lengths);
- generator 3.0.0's own simulation run from the source garment: the source body unposed to
  rest, morphed into the target's shape and posed into the target's pose
  (:mod:`dressmeup.data.synth.quasistatic`, anchors from the source garment's top rows).
"""

from __future__ import annotations

import numpy as np
import pytest

EDITION = "synth-retarget-tiny-v4"
#: the edition before the current one: its whole-edition checks run with the slow tests
pytestmark = pytest.mark.slow


class _Public:
    """What a participant has of one pair: the source garment, both bodies posed."""

    def __init__(self, public_root, pair):
        from dressmeup.body import get_body_model
        from dressmeup.data import Dataset

        ds = Dataset(public_root)
        src, tgt = ds[pair.source.sample_id], ds[pair.target.sample_id]
        self.model = get_body_model("procedural")
        self.keep, self.body_F = self.model.skin()
        g = src.garment()
        self.V, self.F = np.asarray(g.vertices, np.float64), np.asarray(g.faces, np.int64)
        self.src_params, self.tgt_params = src.body(), tgt.body()
        from dressmeup.data.synth.garments import BodyFrame

        rest = self.model.posed(self.model.default_params())
        self.up = BodyFrame.from_joints(rest.rest_joints, tuple(self.model.joint_names)).up

    def posed(self, params, shape=None, pose=None):
        from dressmeup.body import BodyParams

        p = BodyParams(model=self.model.name,
                       shape=params.shape if shape is None else shape,
                       pose=params.pose if pose is None else pose)
        return np.asarray(self.model.posed(p).vertices, np.float64)[self.keep]


def _transfer(pub: _Public) -> np.ndarray:
    from dressmeup.data.synth.generator2 import transfer_to_body

    return transfer_to_body(pub.V, pub.posed(pub.src_params), pub.posed(pub.tgt_params),
                            pub.body_F)


def _relaxed(pub: _Public) -> np.ndarray:
    from dressmeup.data.synth.drape import drape
    from dressmeup.data.synth.generator2 import drape_settings_2x

    start = _transfer(pub)
    return drape(pub.V, pub.F, start, np.zeros(len(pub.V)), pub.posed(pub.tgt_params),
                 pub.body_F, pub.up, drape_settings_2x(), exact_faces=True).vertices


def _simulated(pub: _Public) -> np.ndarray:
    from dressmeup.data.synth.common import BodyAnchors
    from dressmeup.data.synth.quasistatic import Dresser, DressSettings, path_bodies

    settings = DressSettings()
    up = pub.up
    src_body = pub.posed(pub.src_params)
    top = pub.V @ up > np.quantile(pub.V @ up, 0.9)  # a garment hangs from its top
    dresser = Dresser(pub.V, pub.F, BodyAnchors(pub.V, top.astype(float), src_body, pub.body_F),
                      pub.body_F, up, settings)
    s0, s1 = np.asarray(pub.src_params.shape), np.asarray(pub.tgt_params.shape)
    q0, q1 = np.asarray(pub.src_params.pose), np.asarray(pub.tgt_params.pose)
    x = pub.V
    for body_at in (lambda t: pub.posed(pub.src_params, s0, q0 * (1 - t)),
                    lambda t: pub.posed(pub.src_params, (1 - t) * s0 + t * s1, q0 * 0),
                    lambda t: pub.posed(pub.src_params, s1, q1 * t)):
        path = path_bodies(body_at, body_at(0.0), x, settings)
        x, _ = dresser.follow(x, path)
    return x


SHORTCUTS = {"unchanged": lambda pub: pub.V, "relaxed": _relaxed, "simulated": _simulated}


def test_no_shortcut_beats_the_best_reference(shortcut_check, tmp_path):
    check = shortcut_check(EDITION)
    pairs = check.pairs
    assert len(pairs) == 6 and {p.track for p in pairs} == {"re-pose", "re-shape", "cross"}
    reference = check.references(tmp_path)
    best = min(reference.values())
    found = check.shortcuts(tmp_path, SHORTCUTS, _Public)
    closer = {k: v for k, v in found.items() if v < best}
    assert not closer, (f"shortcuts closer to the ground truth than the best reference "
                        f"({best * 1000:.2f} mm, {reference}): "
                        f"{ {k: round(v * 1000, 2) for k, v in closer.items()} }")
