"""The depth-noise model of synthetic captures: Kinect-like axial noise, dropouts at grazing
angles and on dark albedo, flying pixels at depth edges, colour noise, label-mask errors."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["NoiseModel"]


@dataclass
class NoiseModel:
    """Kinect-like depth noise.

    Attributes
    ----------
    enabled : bool, False gives exact depth (still quantised to the depth unit).
    sigma_base : float, metres, constant part of the axial noise standard deviation.
    sigma_quadratic : float, metres per metre^2: sigma(z) = sigma_base + sigma_quadratic * z^2.
    grazing_cos_full, grazing_cos_none : float, dropout probability rises linearly from 0 where
        cos(view angle) >= ``grazing_cos_none`` to 1 at ``grazing_cos_full``.
    dark_luminance : float, albedo luminance below which pixels start to drop out (IR absorption).
    dark_max_dropout : float, dropout probability at luminance 0.
    flying_threshold : float, metres; a depth jump larger than this between 4-neighbours is an edge.
    flying_probability : float, chance that an edge pixel becomes a flying pixel (a depth
        between foreground and background, or up to ``flying_max_tail`` behind the foreground).
    flying_max_tail : float, metres.
    color_sigma : float, colour noise standard deviation on 0..255.
    depth_unit : float, metres per stored unit (quantisation).
    mask_boundary_px : int, label-mask boundary errors (see :meth:`corrupt_labels`; 0: exact).
    mask_blobs : int, wrongly labelled blobs per view (0: none).
    disparity_step : float, metres per metre^2; a structured-light sensor measures disparity in
        steps, so depth comes in steps of ``disparity_step * z^2`` (Kinect v1: 0.0029, 1/8 px
        of disparity at a 7.5 cm baseline and 580 px focal length, 6.5 mm at 1.5 m; 0: off).
    radial_bias : float, relative depth error at the image corners growing with the squared
        distance from the image centre, the same in every frame (an uncalibrated Kinect v1's
        depth distortion, about 0.005-0.01; 0: off).

    :meth:`kinect_v1` returns the settings of a Kinect v1 (structured light).
    """

    enabled: bool = True
    sigma_base: float = 0.0005
    sigma_quadratic: float = 0.0003
    grazing_cos_full: float = 0.08
    grazing_cos_none: float = 0.25
    dark_luminance: float = 0.08
    dark_max_dropout: float = 0.8
    flying_threshold: float = 0.05
    flying_probability: float = 0.5
    flying_max_tail: float = 0.3
    color_sigma: float = 2.0
    depth_unit: float = 0.001
    mask_boundary_px: int = 0
    mask_blobs: int = 0
    disparity_step: float = 0.0
    radial_bias: float = 0.0

    @classmethod
    def kinect_v1(cls, **overrides) -> NoiseModel:
        """A Kinect v1: axial noise 1.2 mm + 1.9 mm/m^2 (Nguyen et al. 2012), depth in
        disparity steps, a 0.6 % radial depth distortion, 1 mm storage unit."""
        return cls(**{"sigma_base": 0.0012, "sigma_quadratic": 0.0019, "disparity_step": 0.0029,
                      "radial_bias": 0.006, **overrides})

    def corrupt_labels(self, labels: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Imitate a 2D human-parsing model's errors on an exact label mask.

        Each label region (>= 1) grows or shrinks by up to ``mask_boundary_px`` pixels (its own
        random amount per view) and ``mask_blobs`` discs of 4-12 px radius inside the
        silhouette take a wrong label. Background (0) is left alone. Off by default.

        Parameters
        ----------
        labels : (h, w) uint8, rng : numpy Generator.

        Returns
        -------
        (h, w) uint8
        """
        out = labels.copy()
        fg = labels > 0
        present = [int(v) for v in np.unique(labels) if v > 0]
        if self.mask_boundary_px > 0:
            for lab in present:
                k = int(rng.integers(-self.mask_boundary_px, self.mask_boundary_px + 1))
                if k == 0:
                    continue
                mask = (out == lab).astype(np.uint8)
                ker = np.ones((2 * abs(k) + 1,) * 2, np.uint8)
                if k > 0:
                    grown = cv2.dilate(mask, ker) > 0
                    out[grown & fg] = lab
                else:
                    shrunk = cv2.erode(mask, ker) > 0
                    lost = (mask > 0) & ~shrunk
                    # lost pixels take the most common other label around them
                    others = np.where(out == lab, 0, out).astype(np.uint8)
                    spread = cv2.dilate(others, np.ones((2 * abs(k) + 3,) * 2, np.uint8))
                    out[lost & (spread > 0)] = spread[lost & (spread > 0)]
        if self.mask_blobs > 0 and len(present) > 1:
            ys, xs = np.nonzero(fg)
            for _ in range(self.mask_blobs):
                if len(ys) == 0:
                    break
                i = int(rng.integers(len(ys)))
                r = int(rng.integers(4, 13))
                disc = np.zeros(labels.shape, np.uint8)
                cv2.circle(disc, (int(xs[i]), int(ys[i])), r, 1, -1)
                wrong = [v for v in present if v != labels[ys[i], xs[i]]]
                out[(disc > 0) & fg] = wrong[int(rng.integers(len(wrong)))]
        return out

    def sigma(self, z: np.ndarray) -> np.ndarray:
        """Axial noise standard deviation (metres) at depth ``z`` (metres)."""
        return self.sigma_base + self.sigma_quadratic * np.asarray(z) ** 2

    def apply(self, depth: np.ndarray, cos_view: np.ndarray, luminance: np.ndarray,
              rng: np.random.Generator) -> np.ndarray:
        """Corrupt an exact depth image.

        Parameters
        ----------
        depth : (h, w) float, exact depth in metres (0 = no surface).
        cos_view : (h, w) float, cosine between the surface normal and the ray towards the camera.
        luminance : (h, w) float in [0, 1], albedo luminance.
        rng : numpy Generator.

        Returns
        -------
        (h, w) float32 noisy depth in metres, quantised to ``depth_unit``, 0 = dropout.
        """
        d = np.asarray(depth, dtype=np.float64).copy()
        valid = d > 0
        if self.enabled:
            d[valid] += rng.normal(size=int(valid.sum())) * self.sigma(d[valid])
            span = max(self.grazing_cos_none - self.grazing_cos_full, 1e-9)
            p_graze = np.clip((self.grazing_cos_none - cos_view) / span, 0.0, 1.0)
            p_dark = self.dark_max_dropout * np.clip((self.dark_luminance - luminance) / max(self.dark_luminance, 1e-9), 0, 1)
            p = 1.0 - (1.0 - p_graze) * (1.0 - p_dark)
            drop = valid & (rng.random(d.shape) < p)
            # flying pixels at depth edges: mix foreground and background
            exact = np.asarray(depth, dtype=np.float64)
            big = np.where(exact > 0, exact, np.inf)
            fly = np.zeros(d.shape, dtype=bool)
            far = np.zeros(d.shape)
            padded = np.pad(big, 1, mode="edge")
            h, w = big.shape
            for dy, dx in ((0, 1), (0, -1), (1, 0), (-1, 0)):
                nb = padded[1 + dy:1 + dy + h, 1 + dx:1 + dx + w]
                edge = valid & (nb - exact > self.flying_threshold)
                fly |= edge
                far = np.where(edge, np.maximum(far, np.where(np.isfinite(nb), nb, exact + self.flying_max_tail)), far)
            fly &= rng.random(d.shape) < self.flying_probability
            u = rng.random(d.shape)
            d = np.where(fly, exact + u * (far - exact), d)
            d[drop & ~fly] = 0.0
            if self.radial_bias:
                h, w = d.shape
                yy, xx = np.mgrid[0:h, 0:w]
                r2 = (((xx - (w - 1) / 2) / (w / 2)) ** 2 + ((yy - (h - 1) / 2) / (h / 2)) ** 2) / 2
                d *= 1.0 + self.radial_bias * r2
            if self.disparity_step > 0:
                # depth -> disparity (1 / z in steps of disparity_step) -> depth
                ok = d > 0
                inv = np.round(1.0 / (d[ok] * self.disparity_step)) * self.disparity_step
                d[ok] = 1.0 / np.maximum(inv, 1e-9)
        d[~valid] = 0.0
        if self.depth_unit > 0:
            d = np.round(d / self.depth_unit) * self.depth_unit
        d[d < 0] = 0
        return d.astype(np.float32)
