"""The secret of a secret test split: new secrets, secret files, commitment and seeds derived
from it, checked against hashlib/hmac computed here independently."""

from __future__ import annotations

import hashlib
import hmac
import os

import numpy as np
import pytest

from dressmeup.data.synth.secret import (
    commitment,
    derive_seed,
    new_secret,
    parse_secret,
    read_secret,
)
from dressmeup.errors import InputError

KNOWN = bytes(range(32))  # 000102...1f
KNOWN_HEX = KNOWN.hex()


def test_new_secret_is_64_lowercase_hex_and_fresh():
    a, b = new_secret(), new_secret()
    assert len(a) == 64 and a == a.lower() and bytes.fromhex(a).hex() == a
    assert a != b


def test_commitment_is_the_sha256_of_the_secret_bytes():
    assert commitment(KNOWN) == hashlib.sha256(KNOWN).hexdigest()
    # known answer: sha256 of the bytes 0x00..0x1f
    assert commitment(KNOWN) == \
        "630dcd2966c4336691125448bbb25b4ff412a49c732db2c8abc1b8581bd710dd"
    assert commitment(KNOWN) != hashlib.sha256(KNOWN_HEX.encode()).hexdigest()


def test_derive_seed_known_answer():
    message = b'["dressmeup-seed/1","test","garment",3]'
    digest = hmac.new(KNOWN, message, hashlib.sha256).digest()
    expected = [int.from_bytes(digest[i:i + 4], "big") for i in range(0, 32, 4)]
    assert derive_seed(KNOWN, "test", "garment", 3) == expected
    assert all(0 <= w < 2 ** 32 for w in expected) and len(expected) == 8


def test_derive_seed_separates_labels_and_secrets():
    seeds = {tuple(derive_seed(KNOWN, *labels)) for labels in
             [("test",), ("test", 1), ("test", "1"), ("test1",), ("val", 1), ("test", 1, 0)]}
    assert len(seeds) == 6
    other = bytes(32)
    assert derive_seed(other, "test", 1) != derive_seed(KNOWN, "test", 1)
    assert derive_seed(KNOWN, "test", 1) == derive_seed(KNOWN, "test", 1)


def test_derive_seed_seeds_numpy_reproducibly():
    a = np.random.default_rng(derive_seed(KNOWN, "test", "pose", 0)).random(4)
    b = np.random.default_rng(derive_seed(KNOWN, "test", "pose", 0)).random(4)
    c = np.random.default_rng(derive_seed(KNOWN, "test", "pose", 1)).random(4)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, c)


@pytest.mark.parametrize("labels", [(), (True,), (1.5,), (None,), ("a", b"b")])
def test_derive_seed_refuses_bad_labels(labels):
    with pytest.raises((TypeError, ValueError)):
        derive_seed(KNOWN, *labels)


@pytest.mark.parametrize("secret", [KNOWN_HEX, KNOWN[:31], KNOWN + b"\0", None])
def test_secret_must_be_32_bytes(secret):
    with pytest.raises(TypeError, match="32 bytes"):
        commitment(secret)
    with pytest.raises(TypeError, match="32 bytes"):
        derive_seed(secret, "test")


def test_read_secret_round_trip(tmp_path):
    for text in (KNOWN_HEX, KNOWN_HEX + "\n"):
        path = tmp_path / "s.secret"
        path.write_text(text, encoding="ascii")
        assert read_secret(path) == KNOWN
    assert parse_secret(KNOWN_HEX, "x") == KNOWN


@pytest.mark.parametrize("text, why", [
    (KNOWN_HEX.upper(), "not all 0-9a-f"),
    (KNOWN_HEX[:-1], "got 63 characters"),
    (KNOWN_HEX + "\n\n", "longer than a secret"),
    (KNOWN_HEX + " ", "got 65 characters"),
    (KNOWN_HEX[:-1] + "\r\n", "got 64 characters that are not all 0-9a-f"),
    ("", "got 0 characters"),
    (KNOWN_HEX + KNOWN_HEX, "longer than a secret"),
])
def test_read_secret_refuses_other_files_naming_them(tmp_path, text, why):
    path = tmp_path / "bad.secret"
    path.write_bytes(text.encode("ascii"))
    with pytest.raises(InputError, match=why) as err:
        read_secret(path)
    assert str(path) in str(err.value)
    assert KNOWN_HEX[:16] not in str(err.value).lower()  # never repeats what it read


def test_read_secret_refuses_binary_and_missing_files(tmp_path):
    path = tmp_path / "bin.secret"
    path.write_bytes(bytes(range(200, 232)) * 2)
    with pytest.raises(InputError, match=str(path)):
        read_secret(path)
    with pytest.raises(InputError, match="cannot read"):
        read_secret(tmp_path / "missing.secret")
    with pytest.raises(InputError, match="cannot read"):
        read_secret(tmp_path)


def test_read_secret_accepts_a_read_only_store(tmp_path):
    # the permissions are the store's business (module docstring)
    path = tmp_path / "team.secret"
    path.write_text(KNOWN_HEX + "\n", encoding="ascii")
    os.chmod(path, 0o444)
    assert read_secret(path) == KNOWN
