"""The dataset pin of a benchmark edition: what data the edition is scored on.

A generated dataset is pinned by generator, generator version, parameters and seed (and,
optionally, the sha256 of the manifest that generator writes); a real one by the sha256 of
its manifest (:mod:`dressmeup.bench.edition`). A generated dataset may have a secret test
split (``test_split``: the commitment to the secret that seeds it and, once published, the
secret; :mod:`dressmeup.data.synth.secret`).
"""

from __future__ import annotations

import copy
import re
from dataclasses import dataclass, field
from typing import Any

from dressmeup.data.synth.secret import commitment, parse_secret
from dressmeup.errors import InputError

__all__ = ["DatasetPin", "parse_pin"]


@dataclass(frozen=True)
class DatasetPin:
    """What data an edition is scored on.

    Attributes
    ----------
    kind : ``"generated"`` (pinned by generator, its version, parameters and seed) or
        ``"real"`` (pinned by the sha256 of the dataset's manifest file).
    generator : generator name, e.g. ``"dressmeup-synth"`` (generated only).
    generator_version : generator version string (generated only).
    params : generator parameters (generated only).
    seed : generator seed (generated only).
    manifest_sha256 : sha256 hex digest of the manifest file (real only).
    name : optional human name of the dataset.
    expected_manifest_sha256 : generated only, optional (v3 editions): the sha256 of the
        manifest the pinned generator writes; scoring refuses data whose manifest differs
        unless asked to score it as "not comparable".
    test_split : generated only, optional: the test split is seeded by a secret,
        ``{"commitment": sha256 hex of the secret, "secret": None or the published secret
        (64 hex)}``. The published secret is not part of the edition's hash: publishing it
        (a small local edition, or the reveal of a retired one) changes no protocol.
    """

    kind: str
    generator: str | None = None
    generator_version: str | None = None
    params: dict[str, Any] = field(default_factory=dict)
    seed: int | None = None
    manifest_sha256: str | None = None
    name: str | None = None
    expected_manifest_sha256: str | None = None
    test_split: dict[str, str | None] | None = None

    @property
    def test_split_commitment(self) -> str | None:
        """The commitment to the secret seeding the test split, or None (seeded publicly)."""
        return self.test_split["commitment"] if self.test_split else None

    @property
    def published_secret(self) -> bytes | None:
        """The test split's secret when the edition publishes it, else None."""
        text = self.test_split.get("secret") if self.test_split else None
        return bytes.fromhex(text) if text else None

    @property
    def sealed(self) -> bool:
        """Whether the test split is seeded by a secret the edition does not publish (only
        whoever holds the secret file generates it)."""
        return bool(self.test_split_commitment) and self.published_secret is None

    @property
    def pinned_manifest_sha256(self) -> str | None:
        """The manifest sha256 the data must have (real pin or generated expectation)."""
        return self.manifest_sha256 if self.kind == "real" else self.expected_manifest_sha256

    def to_dict(self, include_secret: bool = True) -> dict[str, Any]:
        """Serialise (only the fields that apply to ``kind``); ``include_secret=False`` leaves
        the published secret out (the hashed form)."""
        if self.kind == "generated":
            d: dict[str, Any] = {"kind": "generated", "generator": self.generator,
                                 "generator_version": self.generator_version,
                                 "params": copy.deepcopy(self.params), "seed": self.seed}
            if self.expected_manifest_sha256:
                d["expected_manifest_sha256"] = self.expected_manifest_sha256
            if self.test_split:
                d["test_split"] = {"commitment": self.test_split["commitment"]}
                if include_secret:
                    d["test_split"]["secret"] = self.test_split.get("secret")
        else:
            d = {"kind": "real", "manifest_sha256": self.manifest_sha256}
        if self.name:
            d["name"] = self.name
        return d


def parse_pin(d: Any) -> tuple[DatasetPin | None, list[str]]:
    """The ``dataset`` field of an edition as a :class:`DatasetPin`, or None and every
    problem found (each naming its ``dataset.<field>``)."""
    problems: list[str] = []
    if not isinstance(d, dict):
        return None, [f"dataset must be an object, got {type(d).__name__}"]
    kind = d.get("kind")
    name = d.get("name")
    if kind == "generated":
        for key in ("generator", "generator_version", "params", "seed"):
            if key not in d:
                problems.append(f"dataset.{key} is required for a generated dataset")
        if "params" in d and not isinstance(d["params"], dict):
            problems.append("dataset.params must be an object")
        if "seed" in d and (not isinstance(d["seed"], int) or isinstance(d["seed"], bool)):
            problems.append(f"dataset.seed must be an integer, got {d['seed']!r}")
        extra = set(d) - {"kind", "generator", "generator_version", "params", "seed", "name",
                          "expected_manifest_sha256", "test_split"}
        problems += [f"unknown field dataset.{k}" for k in sorted(extra)]
        exp = d.get("expected_manifest_sha256")
        if exp is not None and (not isinstance(exp, str) or not re.fullmatch(r"[0-9a-f]{64}", exp)):
            problems.append(f"dataset.expected_manifest_sha256 must be a sha256 hex digest, "
                            f"got {exp!r}")
        for key in ("secret", "splits"):
            if isinstance(d.get("params"), dict) and key in d["params"]:
                problems.append(f"dataset.params.{key}: not a generator parameter of an edition "
                                "(a secret test split is dataset.test_split)")
        test_split = _parse_test_split(d.get("test_split"), problems)
        if problems:
            return None, problems
        return DatasetPin(kind="generated", generator=str(d["generator"]),
                          generator_version=str(d["generator_version"]),
                          params=dict(d["params"]), seed=int(d["seed"]), name=name,
                          expected_manifest_sha256=exp, test_split=test_split), []
    if kind == "real":
        sha = d.get("manifest_sha256")
        if not isinstance(sha, str) or not re.fullmatch(r"[0-9a-f]{64}", sha):
            problems.append(f"dataset.manifest_sha256 must be a sha256 hex digest, got {sha!r}")
        extra = set(d) - {"kind", "manifest_sha256", "name"}
        problems += [f"unknown field dataset.{k}" for k in sorted(extra)]
        if problems:
            return None, problems
        return DatasetPin(kind="real", manifest_sha256=sha, name=name), []
    return None, [f"dataset.kind must be 'generated' or 'real', got {kind!r}"]


def _parse_test_split(d: Any, problems: list[str]) -> dict[str, str | None] | None:
    """``dataset.test_split`` (absent: None); a published secret must match the commitment
    (appends problems)."""
    if d is None:
        return None
    if not isinstance(d, dict) or set(d) - {"commitment", "secret"} or "commitment" not in d:
        problems.append("dataset.test_split must be {\"commitment\": SHA256_HEX, \"secret\": "
                        f"null or 64 hex}}, got {d!r}")
        return None
    com, text = d["commitment"], d.get("secret")
    if not isinstance(com, str) or not re.fullmatch(r"[0-9a-f]{64}", com):
        problems.append(f"dataset.test_split.commitment must be a sha256 hex digest, got {com!r}")
        return None
    if text is not None:
        try:
            secret = parse_secret(text, "dataset.test_split.secret")
        except InputError as exc:
            problems.append(str(exc))
            return None
        if commitment(secret) != com:
            problems.append("dataset.test_split.secret does not match dataset.test_split."
                            "commitment (its sha256 differs): this is not the edition's secret")
            return None
        text = secret.hex()
    return {"commitment": com, "secret": text}
