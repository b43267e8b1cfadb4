"""The report site written without a browser: pages, pictures, reasons, escaping, CLI."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np


def _pages(site) -> list[Path]:
    return [site.index, *site.edition_pages, *site.method_pages]


def test_site_has_index_edition_and_method_pages(site, site_inputs):
    assert site.index.is_file() and len(site.edition_pages) == 1
    assert len(site.method_pages) == len(site_inputs["results"]) == 4
    index = site.index.read_text()
    for page in site.method_pages:
        assert f'{page.parent.name}/{page.name}"' in index      # linked from the index
    # 2 methods with submissions x (2 best + 2 worst) pictures, plus one category chart
    # per method page
    assert site.images >= 3 * 4 + 4


def test_pictures_exist_and_nothing_is_fetched(site):
    for page in _pages(site):
        text = page.read_text()
        for src in re.findall(r'src="([^"]+)"', text):
            assert not src.startswith(("http:", "https:", "//")), src
            assert (page.parent / src).is_file(), f"{page}: {src} missing"
        assert 'rel="stylesheet"' not in text
        # scripts are classic scripts from files inside the site (file:// loads no module)
        assert 'type="module"' not in text and "import(" not in text
        for src in re.findall(r'<script src="([^"]+)"', text):
            assert site.index.parent.resolve() in (page.parent / src).resolve().parents, src


def test_missing_submission_says_why(site):
    gone = next(p for p in site.method_pages if p.stem == "gone")
    text = gone.read_text()
    assert "is gone" in text and "<img src=\"img/gone-best" not in text
    assert "Every item (18)" in text            # the numbers are still there
    assert "IR (gt)" in text                    # the task's extra column, in %
    assert any("GONE" in n and "is gone" in n for n in site.notes)


def test_method_names_are_escaped(site):
    for page in _pages(site):
        text = page.read_text()
        assert "<script>window.__pwned" not in text
    assert any("&lt;script&gt;window.__pwned" in p.read_text() for p in site.method_pages)


def test_p2s_heat_map_and_penetration_render(tmp_path):
    """The picture shows the error scale: a prediction 10 mm off is drawn in the top colour
    of a 10 mm scale, penetrating faces in pure red."""
    from PIL import Image

    from dressmeup.viz.result_images import (
        PENETRATION_RGB,
        face_distances_mm,
        render_error_pair,
    )

    u, v = np.meshgrid(np.linspace(0, 1, 12), np.linspace(0, 1.5, 18))
    V = np.stack([u.ravel(), v.ravel(), np.zeros(u.size)], 1)
    F = []
    for j in range(17):
        for i in range(11):
            a = j * 12 + i
            F += [[a, a + 1, a + 12], [a + 1, a + 13, a + 12]]
    F = np.asarray(F)
    pred = V + [0.0, 0.0, 0.010]
    err = face_distances_mm(pred, F, V, F)
    assert np.allclose(err, 10.0, atol=1e-6)
    pen = np.zeros(len(F), bool)
    pen[:40] = True
    png = render_error_pair(pred, F, V, F, tmp_path / "x.png", face_error_mm=err,
                            vmax_mm=10.0, penetrating=pen, title="t")
    img = np.asarray(Image.open(png).convert("RGB")).reshape(-1, 3).astype(int)
    red = (np.array(PENETRATION_RGB) * 255).astype(int)
    assert (np.abs(img - red).max(1) < 60).sum() > 50      # shaded red faces present


def test_cli_prints_index(site_inputs, tmp_path, capsys):
    from dressmeup.cli import main

    rc = main(["report", *map(str, site_inputs["results"][:2]), "--data",
               str(site_inputs["data"]), "--out", str(tmp_path / "s"), "--images-per-side",
               "1", "--max-images", "2"])
    out = capsys.readouterr().out
    assert rc == 0 and str((tmp_path / "s" / "index.html").resolve()) in out
    # the picture budget ran out for the second method: its page says so
    pages = sorted((tmp_path / "s").glob("*/*.html"))
    assert any("picture budget" in p.read_text() for p in pages)


def test_fusion_results_get_error_maps(site_inputs, tmp_path):
    """A fusion result (the fixture's scans, shifted 3 mm, as reconstructions) gets error
    maps of the reconstruction against the scan."""
    import json

    from dressmeup.bench import score_submission
    from dressmeup.data import Dataset
    from dressmeup.viz.site import write_site

    ed = json.loads(site_inputs["edition"].read_text())
    ed.update(name="bench-fixture-fusion-v1", task="fusion",
              metrics=["accuracy", "completeness", "fscore_5mm"], primary_metric="accuracy",
              per_category=["accuracy"], options={"n_samples": 2000, "seed": 0})
    ed_path = tmp_path / "fusion.json"
    ed_path.write_text(json.dumps(ed))
    ds = Dataset(site_inputs["data"])
    preds = {}
    for s in ds.filter(split="test"):
        V, F = s.scan()
        preds[s.sample_id] = {"vertices": V + [0.003, 0.0, 0.0], "faces": F}
    from dressmeup.bench import write_submission

    sub = write_submission(tmp_path / "sub", preds, edition=ed_path, method="SHIFTED")
    res = score_submission(sub, ed_path, site_inputs["data"], tmp_path / "res", workers=1,
                           show_progress=False)
    assert res.summary["bootstrap"]["factors"] == ["subject_id", "garment_id", "pose_id"]
    site = write_site([res.path], tmp_path / "site", images_per_side=1)
    page = site.method_pages[0].read_text()
    pics = sorted((tmp_path / "site").glob("*/img/shifted-*.png"))
    assert len([p for p in pics if "per_" not in p.name]) == 2, pics   # best + worst
    assert "is gone" not in page and "could not be drawn" not in page
    # the 3D view: the reconstruction against the scan, no body
    assert 'id="viewer3d"' in page and "distance to scan" in page
    assert 'data-layer="body"' not in page


def test_changed_submission_gets_no_pictures(site_inputs, tmp_path):
    """A submission edited after scoring no longer holds the scored predictions: the page
    says so instead of drawing the wrong ones."""
    import json
    import shutil

    from dressmeup.viz.site import write_site

    res = tmp_path / "res"
    shutil.copytree(site_inputs["results"][0], res)
    summary = json.loads((res / "summary.json").read_text())
    sub = tmp_path / "sub"
    shutil.copytree(summary["submission"]["path"], sub)
    victim = sorted(sub.glob("*.npz"))[0]
    with np.load(victim) as z:
        arrays = {k: z[k] for k in z.files}
    arrays["vertices"] = arrays["vertices"] + 0.01
    np.savez(victim, **arrays)
    summary["submission"]["path"] = str(sub)
    (res / "summary.json").write_text(json.dumps(summary))
    site = write_site([res], tmp_path / "site", data_roots=[site_inputs["data"]])
    text = site.method_pages[0].read_text()
    assert "changed since it was scored" in text and "-best-" not in text


def test_picture_budget_is_shared_between_methods(site_inputs, tmp_path):
    """With 8 item pictures for 4 methods (3 of them with submissions), each gets at least
    its fair share (1 best + 1 worst) instead of the first ones taking everything; what a
    method without pictures leaves goes to the later ones."""
    from dressmeup.viz.site import write_site

    site = write_site(site_inputs["results"], tmp_path / "site",
                      data_roots=[site_inputs["data"]], max_images=8)
    drawn = {}
    for page in site.method_pages:
        drawn[page.stem] = len(list(page.parent.glob(f"img/{page.stem}-best-*.png"))
                               + list(page.parent.glob(f"img/{page.stem}-worst-*.png")))
    assert drawn.pop("gone") == 0
    assert all(n >= 2 for n in drawn.values()) and sum(drawn.values()) == 8, drawn


def test_grouped_bars_without_series_draw_quietly(tmp_path):
    """Every result not comparable leaves a chart with no series: no legend warning."""
    import warnings

    from dressmeup.viz.result_images import render_grouped_bars

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        render_grouped_bars(["re-pose", "cross"], {}, {}, tmp_path / "b.png", ylabel="P2S [mm]")
    assert (tmp_path / "b.png").stat().st_size > 0
