"""Headless pictures: the painter's renderer draws what is in front, contact sheets and UV
checkerboards come out as readable PNGs of the expected size, with the expected colours."""

from __future__ import annotations

import numpy as np
from PIL import Image

from dressmeup.viz.contact_sheet import MeshLayer, render_contact_sheet
from dressmeup.viz.uv_checker import checker_colors, render_uv_checker

RIGHT, UP = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])  # camera looks from +z


def square(z: float, size: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    V = np.array([[-size, -size, z], [size, -size, z], [size, size, z], [-size, size, z]])
    return V, np.array([[0, 1, 2], [0, 2, 3]])


def _rgb(path) -> np.ndarray:
    with Image.open(path) as im:
        return np.asarray(im.convert("RGB"), dtype=np.int64)


def test_nearer_mesh_hides_the_farther_one(tmp_path):
    # a red square in front (z = +1, nearer the +z camera) of a larger blue one; the red is
    # listed first so the order of layers cannot be what puts it on top
    red = MeshLayer(*square(1.0, 0.5), color=(1.0, 0.0, 0.0))
    blue = MeshLayer(*square(0.0, 1.0), color=(0.0, 0.0, 1.0))
    out = tmp_path / "sheet.png"
    render_contact_sheet([[red, blue]], out, RIGHT, UP, ncols=1, cell_size=3.0, dpi=50)
    img = _rgb(out)
    h, w, _ = img.shape
    assert (h, w) == (int(3.0 * 1.25 * 50), int(3.0 * 50))
    centre = img[h // 2 - 3:h // 2 + 3, w // 2 - 3:w // 2 + 3].reshape(-1, 3).mean(0)
    assert centre[0] > 150 and centre[2] < 60  # red in the middle
    ys, xs = np.nonzero((img[..., 2] > 150) & (img[..., 0] < 60))
    assert len(ys) > 500  # the blue square shows around the red one
    r_ys, r_xs = np.nonzero((img[..., 0] > 150) & (img[..., 2] < 60))
    assert xs.min() < r_xs.min() and xs.max() > r_xs.max()


def test_contact_sheet_grid_leaves_missing_cells_blank(tmp_path):
    out = tmp_path / "grid.png"
    cells = [[MeshLayer(*square(0.0), color=(0.2, 0.8, 0.2))] for _ in range(3)]
    render_contact_sheet(cells, out, RIGHT, UP, ncols=2, titles=["a", "b", "c"], cell_size=2.0,
                         dpi=40)
    img = _rgb(out)
    h, w, _ = img.shape
    assert (h, w) == (int(2 * 2.0 * 1.25 * 40), int(2 * 2.0 * 40))
    green = (img[..., 1] > 120) & (img[..., 0] < 100)
    quads = [green[:h // 2, :w // 2], green[:h // 2, w // 2:], green[h // 2:, :w // 2], green[h // 2:, w // 2:]]
    assert all(q.sum() > 100 for q in quads[:3]) and quads[3].sum() == 0


def test_checker_colors_alternate():
    uv = np.array([[0.01, 0.01], [0.07, 0.01], [0.07, 0.07]])
    c = checker_colors(uv, squares=16)
    assert np.allclose(c[0], c[2]) and not np.allclose(c[0], c[1])


def test_uv_checker_picture(tmp_path):
    V, F = square(0.0)
    uv = (V[:, :2] + 1) / 2
    out = render_uv_checker(V, F, uv, F, tmp_path / "uv.png", title="square", squares=4,
                            dpi=40)
    img = _rgb(out)
    assert img.shape[0] > 50 and img.shape[1] > 100
    dark = np.all(np.abs(img - np.array([51, 89, 153])) < 40, axis=2)
    assert dark.sum() > 200  # the dark checker squares are drawn
