"""The test suite's guard: a test that builds generator-2.x data fails unless it is marked
``cpu_kernels`` (tests/conftest.py), because those bytes depend on the CPU's float kernels."""

from __future__ import annotations

import pytest

from dressmeup.data.synth import generate_dataset

TINY_V3 = dict(version="2.1.0", subjects=2, poses=2, garments_per_split=(0, 0, 1),
               categories=["topwear"], body_model="procedural", edge_length=0.05,
               pose_steps=1)


def test_an_unmarked_test_may_not_build_generator_2_data(tmp_path):
    with pytest.raises(pytest.fail.Exception, match="cpu_kernels") as exc:
        generate_dataset(tmp_path / "d", **TINY_V3)
    assert "test_an_unmarked_test_may_not_build_generator_2_data" in str(exc.value)
    assert "synth-retarget-tiny-v4" in str(exc.value)
    assert not (tmp_path / "d").exists()  # refused before anything is written


def test_the_guard_holds_for_the_generator_called_directly(tmp_path):
    from dressmeup.data.synth.generator2 import generate_2x  # the guarded name, as tests import it

    with pytest.raises(pytest.fail.Exception, match="cpu_kernels"):
        generate_2x(tmp_path / "d", subjects=1, poses=1, garments_per_split=(0, 0, 1))


@pytest.mark.cpu_kernels
def test_a_marked_test_reaches_the_generator(tmp_path):
    from dressmeup.data.synth.generator2 import generate_2x  # the guarded name, as tests import it

    # past the guard, the generator itself answers (a bad argument, refused before any work)
    with pytest.raises(ValueError, match="scan_body"):
        generate_2x(tmp_path / "d", subjects=1, poses=1, garments_per_split=(0, 0, 1),
                    scan_body="nope")


def test_generator_3_is_not_guarded(tmp_path):
    # the v4 editions' generator: refused only for its own reasons
    with pytest.raises(Exception, match="pose_set") as exc:
        generate_dataset(tmp_path / "d", version="3.0.0", subjects=1, poses=1,
                         garments_per_split=(0, 0, 1), pose_set="registration")
    assert not isinstance(exc.value, pytest.fail.Exception)
