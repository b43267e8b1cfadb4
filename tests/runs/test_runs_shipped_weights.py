"""The checkpoint a trainable retargeting baseline ships is found for the method itself, for
a method deriving from another's class, and for a post-process chain's base method."""

from __future__ import annotations

import pytest


@pytest.mark.parametrize(("name", "stem"), [
    ("isomap-refine", "isomap_refine"),
    ("isomap-refine-fast", "isomap_refine_fast"),
    ("isomap-refine-sup", "isomap_refine_sup"),
    ("isomap-refine+penetration", "isomap_refine"),
    ("isomap-refine-sup+detail", "isomap_refine_sup"),
])
def test_shipped_weights_of_methods_and_chains(name, stem):
    from dressmeup.methods.retarget import get_method
    from dressmeup.runs.common import shipped_weights

    path = shipped_weights(get_method(name), "anny")
    assert path is not None and path.name == f"{stem}_anny.pt" and path.is_file()
    assert shipped_weights(get_method(name), "procedural") is None


@pytest.mark.parametrize("name", ["skinning", "isomap+penetration", "simulate"])
def test_methods_without_weights_ship_none(name):
    from dressmeup.methods.retarget import get_method
    from dressmeup.runs.common import shipped_weights

    assert shipped_weights(get_method(name), "anny") is None
