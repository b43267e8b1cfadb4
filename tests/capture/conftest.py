"""Small synthetic captures shared by the capture/fusion/extraction tests (tiny images)."""

from __future__ import annotations

import pytest


@pytest.fixture(scope="session")
def small_rig():
    from dressmeup.capture.rig import ring_rig

    return ring_rig(7, name="test").scaled(0.3)  # 192x173 images


@pytest.fixture(scope="session")
def mannequin(small_rig):
    from dressmeup.capture.synthetic import make_mannequin, place_subject

    subject, _ = place_subject(make_mannequin(n_around=96, n_up=140), small_rig)
    return subject


@pytest.fixture(scope="session")
def clean_frames(mannequin, small_rig):
    from dressmeup.capture.synthetic import render_frames

    return render_frames(mannequin, small_rig, None, seed=0)


@pytest.fixture(scope="session")
def session_dir(tmp_path_factory, small_rig):
    from dressmeup.capture.synthetic import NoiseModel, make_mannequin, synth_capture

    out = tmp_path_factory.mktemp("sessions") / "S00-P0"
    synth_capture(make_mannequin(n_around=96, n_up=140), small_rig, out, noise=NoiseModel(), seed=3)
    return out
