"""Secret test splits: an edition's dataset.test_split (commitment, published secret), the
secret a command is given checked against it before any work, and what `dressmeup synth`
and runs.build_data ask of the generator (train and val only without the secret; a
generator that cannot seed a test split from a secret refuses)."""

from __future__ import annotations

import hashlib
import json
import os
import stat

import pytest

from dressmeup.bench.edition import (
    ALL_SPLITS,
    edition_from_dict,
    edition_secret,
    load_edition,
    splits_to_generate,
)
from dressmeup.data.synth import SynthConfig, generate_dataset
from dressmeup.data.synth.secret import read_secret
from dressmeup.errors import InputError
from dressmeup.runs.data import build_data, build_parts

from ..cli.test_cli_hardening import run  # one line errors, fast, no traceback

SECRET = bytes(range(32))
COMMITMENT = hashlib.sha256(SECRET).hexdigest()
OTHER = bytes(32)


def _edition_dict(test_split=None) -> dict:
    d = load_edition("synth-retarget-tiny-v4").to_dict()
    d["name"] = "secret-tiny"  # no probe pin, no archives of its own
    if test_split is not None:
        d["dataset"]["test_split"] = test_split
    return d


@pytest.fixture
def secret_edition(tmp_path):
    """A copy of the tiny v4 edition whose test split is secret (commitment only)."""
    path = tmp_path / "secret-tiny.json"
    path.write_text(json.dumps(_edition_dict({"commitment": COMMITMENT, "secret": None})))
    return path


@pytest.fixture
def secret_file(tmp_path):
    path = tmp_path / "right.secret"
    path.write_text(SECRET.hex() + "\n")
    return path


@pytest.fixture
def wrong_file(tmp_path):
    path = tmp_path / "wrong.secret"
    path.write_text(OTHER.hex() + "\n")
    return path


# ---- the edition field ---------------------------------------------------------------------

def test_test_split_loads_and_round_trips(secret_edition):
    ed = load_edition(secret_edition)
    assert ed.dataset.test_split_commitment == COMMITMENT
    assert ed.dataset.published_secret is None
    again = edition_from_dict(json.loads(json.dumps(ed.to_dict())))
    assert again.hash == ed.hash and again.dataset.test_split == ed.dataset.test_split


def test_no_test_split_leaves_the_shipped_editions_unchanged():
    d = load_edition("synth-retarget-tiny-v4").to_dict()
    assert "test_split" not in d["dataset"]
    assert load_edition("synth-retarget-tiny-v4").dataset.test_split_commitment is None


def test_the_commitment_is_hashed_the_published_secret_is_not():
    secret_only = edition_from_dict(_edition_dict({"commitment": COMMITMENT, "secret": None}))
    revealed = edition_from_dict(_edition_dict({"commitment": COMMITMENT,
                                                "secret": SECRET.hex()}))
    plain = edition_from_dict(_edition_dict())
    other = edition_from_dict(_edition_dict(
        {"commitment": hashlib.sha256(OTHER).hexdigest(), "secret": None}))
    assert revealed.hash == secret_only.hash  # the reveal changes no protocol
    assert len({secret_only.hash, plain.hash, other.hash}) == 3
    assert revealed.dataset.published_secret == SECRET
    assert secret_only.dataset.sealed and not revealed.dataset.sealed and not plain.dataset.sealed
    assert revealed.to_dict()["dataset"]["test_split"]["secret"] == SECRET.hex()
    assert SECRET.hex() not in revealed.canonical_json()


def test_a_published_secret_must_match_the_commitment_naming_the_file(tmp_path):
    path = tmp_path / "bad-reveal.json"
    path.write_text(json.dumps(_edition_dict({"commitment": COMMITMENT, "secret": OTHER.hex()})))
    with pytest.raises(InputError, match="does not match dataset.test_split.commitment") as err:
        load_edition(path)
    assert str(path) in str(err.value)


@pytest.mark.parametrize("test_split, says", [
    ({"commitment": COMMITMENT.upper(), "secret": None}, "commitment must be a sha256"),
    ({"commitment": COMMITMENT[:-1], "secret": None}, "commitment must be a sha256"),
    ({"secret": None}, "test_split must be"),
    ({"commitment": COMMITMENT, "secret": None, "seed": 1}, "test_split must be"),
    ("abc", "test_split must be"),
    ({"commitment": COMMITMENT, "secret": SECRET.hex()[:-2]}, "exactly 64 lowercase hex"),
    ({"commitment": COMMITMENT, "secret": 5}, "a secret is a string"),
])
def test_bad_test_splits_are_refused(test_split, says):
    with pytest.raises(InputError, match=says):
        edition_from_dict(_edition_dict(test_split), source="x.json")


@pytest.mark.parametrize("key", ["secret", "splits"])
def test_a_secret_is_never_a_generator_parameter(key):
    d = _edition_dict()
    d["dataset"]["params"][key] = SECRET.hex()
    with pytest.raises(InputError, match=f"dataset.params.{key}"):
        edition_from_dict(d)


# ---- the secret a command is given ---------------------------------------------------------

def test_edition_secret(secret_edition, secret_file, wrong_file):
    ed = load_edition(secret_edition)
    assert edition_secret(ed) is None
    assert splits_to_generate(ed, None) == ("train", "val")
    assert edition_secret(ed, secret_file) == SECRET
    assert splits_to_generate(ed, SECRET) == ALL_SPLITS
    with pytest.raises(InputError, match="is not the secret of edition secret-tiny") as err:
        edition_secret(ed, wrong_file)
    assert str(wrong_file) in str(err.value) and str(secret_edition) in str(err.value)


def test_edition_secret_of_revealed_and_public_editions(secret_file, wrong_file):
    revealed = edition_from_dict(_edition_dict({"commitment": COMMITMENT,
                                                "secret": SECRET.hex()}))
    assert edition_secret(revealed) == SECRET
    assert edition_secret(revealed, secret_file) == SECRET
    with pytest.raises(InputError, match="is not the secret"):
        edition_secret(revealed, wrong_file)
    plain = load_edition("synth-retarget-tiny-v4")
    assert edition_secret(plain) is None and splits_to_generate(plain, None) == ALL_SPLITS
    with pytest.raises(InputError, match="has no secret test split"):
        edition_secret(plain, secret_file)


# ---- the generator -------------------------------------------------------------------------

def test_the_secret_is_not_shown_by_the_config():
    config = SynthConfig(secret=SECRET)
    assert SECRET.hex() not in repr(config) and repr(SECRET) not in repr(config)


@pytest.mark.parametrize("settings", [{"secret": SECRET}, {"splits": ("train", "val")}])
@pytest.mark.parametrize("version", ["1.1.0", "2.1.0", "3.0.0"])
def test_generators_without_secrets_refuse_before_any_work(tmp_path, version, settings):
    out = tmp_path / "data"
    with pytest.raises(InputError, match=f"generator {version} cannot build a secret test"):
        generate_dataset(out, version=version, body_model="procedural", **settings)
    assert not out.exists()


def test_splits_must_be_known(tmp_path):
    with pytest.raises(InputError, match="subset of train, val, test"):
        generate_dataset(tmp_path / "d", splits=("train", "holdout"))


# ---- dressmeup synth -----------------------------------------------------------------------

def test_synth_refuses_a_wrong_secret_before_any_work(secret_edition, wrong_file, tmp_path,
                                                      capsys):
    out = tmp_path / "data"
    status, _, err = run(["synth", out, "--edition", secret_edition, "--secret", wrong_file],
                         capsys)
    assert status != 0 and "is not the secret of edition secret-tiny" in err
    assert str(wrong_file) in err
    assert not out.exists()


@pytest.mark.parametrize("with_secret", [False, True])
def test_synth_refuses_a_generator_without_secrets(secret_edition, secret_file, tmp_path,
                                                   capsys, with_secret):
    out = tmp_path / "data"
    argv = ["synth", out, "--edition", secret_edition]
    status, _, err = run(argv + (["--secret", secret_file] if with_secret else []), capsys)
    assert status != 0
    assert "edition secret-tiny: generator 3.0.0 cannot build a secret test split" in err
    assert SECRET.hex() not in err
    assert not out.exists()


def test_synth_without_the_secret_builds_train_and_val(secret_edition, tmp_path, capsys,
                                                       monkeypatch):
    asked = []

    def fake_generate(out, config=None, **kw):
        asked.append(config)
        os.makedirs(out)
        return out

    # a generator that reads secrets (none ships yet): what the command asks of it
    monkeypatch.setattr("dressmeup.data.synth.config.SECRET_VERSIONS", frozenset({"3.0.0"}))
    monkeypatch.setattr("dressmeup.data.synth.generate_dataset", fake_generate)
    status, out, err = run(["synth", tmp_path / "data", "--edition", secret_edition], capsys)
    assert status == 0, err
    assert [c.splits for c in asked] == [("train", "val")] and asked[0].secret is None
    assert asked[0].seed == 0 and asked[0].version == "3.0.0"
    lines = out.strip().splitlines()
    assert len(lines) == 1
    assert "dressmeup edition fetch secret-tiny" in lines[0] and "train and val" in lines[0]


def test_synth_with_the_secret_builds_every_split(secret_edition, secret_file, tmp_path,
                                                  capsys, monkeypatch):
    asked = []

    def fake_generate(out, config=None, **kw):
        asked.append(config)
        raise InputError("stop here")  # what it was asked is the point

    monkeypatch.setattr("dressmeup.data.synth.config.SECRET_VERSIONS", frozenset({"3.0.0"}))
    monkeypatch.setattr("dressmeup.data.synth.generate_dataset", fake_generate)
    status, out, err = run(["synth", tmp_path / "data", "--edition", secret_edition,
                            "--secret", secret_file], capsys)
    assert status != 0 and "stop here" in err
    assert asked[0].splits == ALL_SPLITS and asked[0].secret == SECRET
    assert SECRET.hex() not in out + err


def test_synth_secret_needs_an_edition(secret_file, tmp_path, capsys):
    status, _, err = run(["synth", tmp_path / "d", "--secret", secret_file], capsys)
    assert status != 0 and "--secret goes with --edition" in err


# ---- runs.build_data / build_parts ---------------------------------------------------------

def test_build_data_without_the_secret(secret_edition, tmp_path, monkeypatch):
    asked = []

    def fake_generate(out, **settings):
        asked.append(settings)
        return out

    monkeypatch.setattr("dressmeup.runs.data.generate_dataset", fake_generate)
    lines = []
    build_data(secret_edition, tmp_path / "d", log=lines.append)
    assert asked[0]["splits"] == ("train", "val") and asked[0]["secret"] is None
    assert "dressmeup edition fetch secret-tiny" in lines[-1]


def test_build_data_refuses_a_wrong_secret_and_a_generator_without_secrets(
        secret_edition, secret_file, wrong_file, tmp_path):
    with pytest.raises(InputError, match="is not the secret"):
        build_data(secret_edition, tmp_path / "a", secret_file=wrong_file)
    with pytest.raises(InputError, match="generator 3.0.0 cannot build a secret test split"):
        build_data(secret_edition, tmp_path / "b", secret_file=secret_file)
    assert not (tmp_path / "a").exists() and not (tmp_path / "b").exists()


def test_build_parts_needs_the_secret(secret_edition, tmp_path):
    with pytest.raises(InputError, match="built by whoever holds the secret"):
        build_parts(secret_edition, tmp_path / "parts")
    assert not (tmp_path / "parts").exists()


# ---- dressmeup edition secret --------------------------------------------------------------

def test_edition_secret_command(tmp_path, capsys):
    path = tmp_path / "v5.secret"
    status, out, err = run(["edition", "secret", "--out", path], capsys)
    assert status == 0, err
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    secret = read_secret(path)
    assert f"commitment {hashlib.sha256(secret).hexdigest()}" in out
    assert secret.hex() not in out
    before = path.read_bytes()
    status, _, err = run(["edition", "secret", "--out", path], capsys)
    assert status != 0 and "already exists" in err and path.read_bytes() == before
    status, _, err = run(["edition", "secret", "--out", tmp_path / "no" / "s.secret"], capsys)
    assert status != 0 and "does its folder exist" in err
