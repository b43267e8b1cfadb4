"""The generator's configuration: keywords replace fields, unknown ones are refused."""

import dataclasses

import pytest

from dressmeup.data.synth import GENERATOR_VERSION, SynthConfig, generate_dataset, synth_config
from dressmeup.errors import InputError


def test_keywords_replace_the_fields_of_a_config():
    base = SynthConfig(version="2.1.0", subjects=4, poses=3)
    c = synth_config(base, poses=2, seed=7)
    assert (c.version, c.subjects, c.poses, c.seed) == ("2.1.0", 4, 2, 7)
    assert base.poses == 3  # frozen: the original is unchanged
    assert synth_config().version == GENERATOR_VERSION
    with pytest.raises(dataclasses.FrozenInstanceError):
        c.poses = 5


def test_an_unknown_setting_is_refused_naming_the_known_ones(tmp_path):
    with pytest.raises(InputError, match="unknown generator setting.*'subject'.*subjects"):
        synth_config(subject=3)
    with pytest.raises(InputError, match="unknown generator setting"):
        generate_dataset(tmp_path / "d", garmnets=2)
    assert not (tmp_path / "d").exists()  # refused before anything is written


def test_a_config_and_its_keywords_generate_the_same_data(tmp_path):
    kw = dict(subjects=1, garments=1, poses=2, seed=3, body_model="procedural",
              edge_length=0.06, write_scan=False, texture_size=16)
    a = generate_dataset(tmp_path / "a", **kw)
    b = generate_dataset(tmp_path / "b", SynthConfig(**kw))
    assert (a / "manifest.parquet").read_bytes() == (b / "manifest.parquet").read_bytes()
