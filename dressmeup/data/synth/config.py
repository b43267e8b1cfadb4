"""What a generated dataset is a function of: one frozen configuration of the generator.

:func:`dressmeup.data.synth.generate_dataset` takes a :class:`SynthConfig` (or its fields as
keywords, checked by :func:`synth_config`); where it runs (``workers``, ``executor``) is not
part of it, since the output does not depend on it.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import Any

from dressmeup.data.synth.drape import DrapeSettings
from dressmeup.errors import InputError

#: the generator version written when none is asked for (the ``*-v2`` editions' data)
GENERATOR_VERSION = "1.1.0"


@dataclass(frozen=True)
class SynthConfig:
    """Settings of one generated dataset; the dataset is a deterministic function of them.

    Every version reads ``version``, ``subjects``, ``poses``, ``seed``, ``body_model``
    (``anny`` or ``procedural``), ``edge_length`` (garment edge in metres; None: the body
    model's default), ``write_scan`` and ``texture_size`` (pixels).

    Generator 1.1.0 (``version="1.1.0"``) also reads ``garments`` (per subject),
    ``registration_noise`` (std of the noise added to the stored pose, radians, and shape,
    phenotype units), ``types`` (garment types; None: all), ``split_fractions`` (train, val,
    test fractions of garments), ``split_strategy`` (``stratified`` or ``random``) and
    ``drape_settings``.

    Generators 2.x and 3.x read ``garments_per_split`` ((train, val, test) garments per
    category; None: (6, 2, 4)), ``categories`` (None: all) and ``scan_body`` (``whole`` or
    ``uncovered``); 2.x also ``pose_steps``, ``pose_set`` (``generator``, ``registration``
    or ``all``), ``wear`` (``all`` or ``rotate``) and ``drape_settings``; 3.x ``dress``
    (overrides of :class:`dressmeup.data.synth.quasistatic.DressSettings`).

    Generator 4.0.0 (:mod:`dressmeup.data.synth.dataset4`) reads ``plan`` (overrides of
    :class:`dressmeup.data.synth.plan4.PlanDesign`: bodies, poses per family and garments
    per split, targets per track), ``motion`` (of
    :class:`dressmeup.data.synth.motion.MotionSpec`), ``dynamics`` (of
    :class:`dressmeup.data.synth.dynamics.DynamicsSettings`), ``edge_length`` (None: 15 mm),
    ``body_model``, ``write_scan``, ``scan_body``, ``texture_size``, ``seed`` (train and val)
    and ``secret`` (the test split).

    ``splits`` (the splits to build; default all) and ``secret`` (the 32 bytes that seed the
    test split, :mod:`dressmeup.data.synth.secret`; None: the public ``seed`` seeds every
    split) are read only by the generator versions in :data:`SECRET_VERSIONS`; every other
    version refuses a secret or fewer splits. ``secret`` is not shown by ``repr`` and is never
    written anywhere (dataset.json, stats, logs): a generator records its
    :func:`~dressmeup.data.synth.secret.commitment` instead.
    """

    version: str = GENERATOR_VERSION
    subjects: int = 3
    poses: int = 5
    seed: int = 0
    body_model: str = "anny"
    edge_length: float | None = None
    write_scan: bool = True
    texture_size: int = 256
    garments: int = 4
    registration_noise: float = 0.0
    types: list[str] | None = None
    split_fractions: tuple[float, float, float] = (0.6, 0.2, 0.2)
    split_strategy: str = "stratified"
    drape_settings: DrapeSettings | None = None
    garments_per_split: tuple[int, int, int] | list[int] | None = None
    categories: list[str] | None = None
    pose_steps: int = 3
    pose_set: str = "generator"
    wear: str = "all"
    scan_body: str = "whole"
    dress: dict[str, Any] | None = None
    plan: dict[str, Any] | None = None
    motion: dict[str, Any] | None = None
    dynamics: dict[str, Any] | None = None
    splits: tuple[str, ...] = ("train", "val", "test")
    secret: bytes | None = field(default=None, repr=False)


FIELDS = tuple(f.name for f in dataclasses.fields(SynthConfig))
#: generator versions that seed a test split from a secret and can build a subset of the
#: splits (``SynthConfig.splits``, ``SynthConfig.secret``)
SECRET_VERSIONS: frozenset[str] = frozenset({"4.0.0"})


def check_secret_support(c: SynthConfig) -> None:
    """Refuse (:class:`~dressmeup.errors.InputError`) a secret or a subset of the splits asked
    of a generator version that does not read them (not in :data:`SECRET_VERSIONS`)."""
    if set(c.splits) - {"train", "val", "test"} or not c.splits:
        raise InputError(f"splits: a non-empty subset of train, val, test, got {c.splits!r}")
    if c.secret is not None and (not isinstance(c.secret, bytes) or len(c.secret) != 32):
        raise InputError("secret: 32 bytes (dressmeup.data.synth.secret.read_secret)")
    if c.version in SECRET_VERSIONS:
        return
    if c.secret is not None or set(c.splits) != {"train", "val", "test"}:
        supported = ", ".join(sorted(SECRET_VERSIONS)) or "none yet"
        raise InputError(f"generator {c.version} cannot build a secret test split (a test "
                         "split seeded by a secret, or train and val without it): its test "
                         "split comes from the public seed. An edition with "
                         "dataset.test_split needs a generator that does (versions: "
                         f"{supported})")


def synth_config(config: SynthConfig | None = None, **settings: Any) -> SynthConfig:
    """``config`` (default :class:`SynthConfig`) with ``settings`` replaced; an unknown
    setting raises :class:`~dressmeup.errors.InputError` naming the known ones."""
    unknown = sorted(set(settings) - set(FIELDS))
    if unknown:
        raise InputError(f"unknown generator setting(s) {unknown}; known: {', '.join(FIELDS)}")
    return dataclasses.replace(config or SynthConfig(), **settings)
