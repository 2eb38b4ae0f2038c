"""Synthetic camera frames of the coil plane with red markers at known subpixel positions.

`marker_pixels(design, xyz_mm)` projects marker centres through the design's camera (optionally a
measured camera matrix and lens distortion); `render_frame(design, markers_px, ...)` draws what the
camera sees: the purple mount and LED ring, a dark coil block under each marker (oriented
radially), red coil wires, the red markers themselves, uneven light, Gaussian blur and Gaussian
noise. Pixel centres are at integer coordinates (OpenCV's convention). Output: HxWx3 uint8 BGR.

The markers are drawn in the order a camera forms them: the disc is blurred by the optics first and
then integrated over each pixel (`_blurred_disc_alpha`: a 4x finer grid, blurred there, box-averaged
into pixels). Supersampling the sharp disc into pixels and blurring the pixel image afterwards (the
earlier renderer) bakes pixel-grid aliasing into the frame: the drawn marker's centre then wanders
by up to +-0.005 px around the commanded one, in steps that depend on the subpixel phase, which is as
large as the 0.02 px marker motion of a small whisking sweep (benchmarks/results/tracking.md,
"Small steps"). The blur before sampling removes that aliasing (attenuation exp(-2 pi^2 sigma^2) at
one cycle per pixel: 3e-6 for sigma 0.8 px).

Effects it models (and so what tracking benchmarks on it can and cannot say): position, size and
colour of markers; distractors of the real frames (purple mount, white LEDs, dark blocks, red
wires); smooth illumination gradients; blur; sensor noise. Not modelled: JPEG artefacts, motion
blur, specular highlights on the coil windings, the markers' foreshortening when the coil tilts
(a 15 deg tilt shrinks the dot's projected width by 3 %, symmetric, so its centre is unchanged).
"""

from __future__ import annotations

import functools
import math

import numpy as np

from whisker.vision import geometry

# BGR colours measured on the authors' frames (org.jpg): marker red, coil block, purple mount.
MARKER_BGR = (45.0, 40.0, 205.0)
BLOCK_BGR = (38.0, 40.0, 42.0)
MOUNT_BGR = (205.0, 120.0, 150.0)
CAVITY_BGR = (30.0, 26.0, 28.0)
MEMBRANE_BGR = (120.0, 95.0, 90.0)
LED_BGR = (250.0, 250.0, 250.0)
WIRE_BGR = (40.0, 45.0, 190.0)


def marker_pixels(design, xyz_mm, *, mtx=None, dist=None, model: str = "standard") -> np.ndarray:
    """Pixel centres (M, 2) of markers at sensor-frame positions `xyz_mm` (M, 3), mm.

    Pinhole from the design's camera (or the measured matrix `mtx`); `dist` adds OpenCV lens
    distortion of `model` ("standard"/"rational": k1, k2, p1, p2[, k3 ...]; "fisheye": k1..k4).
    See `whisker.vision.geometry.project`.
    """
    return geometry.project(design, xyz_mm, mtx=mtx, dist=dist, model=model)


def marker_radius_px(design) -> float:
    """Marker radius in pixels at the marker plane (design.coil.marker_diameter / 2 / k)."""
    return design.coil.marker_diameter / 2.0 / design.mm_per_px


def _disc_coverage(h: int, w: int, cx: float, cy: float, r: float, ss: int = 8):
    """(y0, x0, coverage patch) of a disc: fraction of each pixel inside it, by ss x ss supersampling.

    The coverage-weighted centroid of the patch is off (cx, cy) by up to ~5e-3 px, depending on the
    subpixel phase (pixel-grid aliasing of the sharp edge); blurred frames use `_blurred_disc_alpha`.
    """
    x0 = max(int(math.floor(cx - r - 1)), 0)
    x1 = min(int(math.ceil(cx + r + 1)) + 1, w)
    y0 = max(int(math.floor(cy - r - 1)), 0)
    y1 = min(int(math.ceil(cy + r + 1)) + 1, h)
    if x1 <= x0 or y1 <= y0:
        return y0, x0, np.zeros((0, 0))
    off = (np.arange(ss) + 0.5) / ss - 0.5
    xs = (np.arange(x0, x1)[:, None] + off[None, :]).ravel() - cx
    ys = (np.arange(y0, y1)[:, None] + off[None, :]).ravel() - cy
    inside = (ys[:, None] ** 2 + xs[None, :] ** 2) <= r * r
    cov = inside.reshape(y1 - y0, ss, x1 - x0, ss).mean(axis=(1, 3))
    return y0, x0, cov


def _chord_coverage(n: int, cx: float, cy: float, r: float, ss: int = 8) -> np.ndarray:
    """(n, n) float32 coverage of a disc on an n x n grid of unit cells (centres at integers): each
    cell's ss sub-rows cut the disc in an exact chord, whose overlap with the cell is exact in x."""
    off = (np.arange(ss) + 0.5) / ss - 0.5
    ys = (np.arange(n)[:, None] + off[None, :]).ravel() - cy
    half = np.sqrt(np.maximum(r * r - ys * ys, 0.0))
    left = np.arange(n) - 0.5 - cx
    ov = np.minimum(left[None, :] + 1.0, half[:, None]) - np.maximum(left[None, :], -half[:, None])
    return np.clip(ov, 0.0, None).reshape(n, ss, n).mean(axis=1).astype(np.float32)


def _blurred_disc_alpha(h: int, w: int, cx: float, cy: float, r: float, blur_px: float, fine: int = 4):
    """(y0, x0, alpha patch) of a disc of radius r px at (cx, cy), blurred by a Gaussian of sigma
    `blur_px` px and then integrated over each pixel (what a camera's optics and pixels do).

    Computed on a grid `fine` times finer than the pixels (chord-exact coverage per fine cell,
    `_chord_coverage`), blurred there with cv2.GaussianBlur (sigma blur_px * fine) and box-averaged into pixels.
    Aliasing of the fine grid is at `fine` cycles per px, where the blur's attenuation
    exp(-2 pi^2 (sigma f)^2) is below 1e-40 for sigma >= 0.5 px.
    """
    import cv2

    m = int(math.ceil(r + 1 + 4.0 * blur_px))   # patch half-size, px: the blur's tail fits
    ix, iy = int(math.floor(cx)), int(math.floor(cy))
    x0, x1 = max(ix - m, 0), min(ix + m + 2, w)
    y0, y1 = max(iy - m, 0), min(iy + m + 2, h)
    if x1 <= x0 or y1 <= y0:
        return y0, x0, np.zeros((0, 0), np.float32)
    # the fine grid spans the whole padded patch (also beyond the image border, then cropped)
    px0, py0 = ix - m, iy - m
    n = 2 * m + 2
    fx, fy = (cx - px0 + 0.5) * fine - 0.5, (cy - py0 + 0.5) * fine - 0.5   # centre on the fine grid
    # chord-exact coverage, once along rows and once along columns (averaged: no preferred axis)
    full = 0.5 * (_chord_coverage(n * fine, fx, fy, r * fine) + _chord_coverage(n * fine, fy, fx, r * fine).T)
    full = cv2.GaussianBlur(full, (0, 0), float(blur_px) * fine, borderType=cv2.BORDER_CONSTANT)
    alpha = full.reshape(n, fine, n, fine).mean(axis=(1, 3))
    return y0, x0, alpha[y0 - py0:y1 - py0, x0 - px0:x1 - px0]


def _blend(img: np.ndarray, y0: int, x0: int, alpha: np.ndarray, bgr) -> None:
    if alpha.size == 0:
        return
    h, w = alpha.shape
    sub = img[y0:y0 + h, x0:x0 + w]
    sub += alpha[..., None] * (np.asarray(bgr, dtype=np.float32) - sub)


@functools.lru_cache(maxsize=8)
def _scene(h, w, cx, cy, ring_px, cavity, k):
    """Background (float32 BGR): purple mount, dark cavity, pale membrane, LED ring. Cached."""
    import cv2

    img = np.empty((h, w, 3), np.float32)
    img[:] = CAVITY_BGR
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    rr = np.hypot(xx - cx, yy - cy)
    img[rr > cavity] = MOUNT_BGR
    img[rr < ring_px - 2.5 / k] = MEMBRANE_BGR
    led = (rr > cavity + 4.0 / k) & (rr < cavity + 7.0 / k)
    img[led & ((np.degrees(np.arctan2(yy - cy, xx - cx)) % 20.0) < 8.0)] = LED_BGR
    img = cv2.GaussianBlur(img, (0, 0), 1.2)
    img.flags.writeable = False
    return img


def render_frame(design, markers_px, *, seed: int = 0, noise_sigma: float = 0.0, blur_px: float = 0.0,
                 wires: bool = True, blocks: bool = True, scene: bool = True, light_gradient: float = 0.0,
                 vignette: float = 0.0, marker_radius: float | None = None, centre_px=None,
                 size: tuple[int, int] | None = None, marker_bgr=MARKER_BGR) -> np.ndarray:
    """Draw one camera frame (H x W x 3 uint8, BGR) with red markers centred at `markers_px` (M, 2).

    noise_sigma: Gaussian noise per channel, grey levels. blur_px: Gaussian blur sigma, px (0 = none).
    wires: two red wires from each coil block outward (the reason the paper erodes its mask).
    blocks: dark coil blocks under the markers. scene: purple mount, dark cavity, pale membrane, LED
    ring. light_gradient: relative brightness change across the image width (0.3 = +-15 %).
    vignette: relative darkening at the corners. marker_radius: px (default from the design).
    centre_px: ring centre for orienting blocks and wires (default: mean of the markers).
    size: (height, width), default from the design's camera. Rows of NaN in markers_px are skipped
    (a marker that is not visible). Markers may lie partly or wholly outside the image.
    """
    h, w = size if size is not None else (design.camera.height_px, design.camera.width_px)
    if h < 1 or w < 1:
        raise ValueError(f"image size must be positive, got {h}x{w}")
    pts = np.asarray(markers_px, dtype=float).reshape(-1, 2)
    if np.any(np.isinf(pts)):
        raise ValueError("markers_px contains inf")
    shown = np.all(np.isfinite(pts), axis=1)
    r_m = marker_radius_px(design) if marker_radius is None else float(marker_radius)
    if not r_m > 0:
        raise ValueError(f"marker_radius must be positive, got {r_m}")
    k = design.mm_per_px
    if centre_px is None:
        centre = pts[shown].mean(axis=0) if shown.any() else np.array([(w - 1) / 2, (h - 1) / 2])
    else:
        centre = np.asarray(centre_px, dtype=float)
    rng = np.random.default_rng(seed)
    if scene:
        img = _scene(h, w, round(float(centre[0]), 1), round(float(centre[1]), 1),
                     design.whiskers.ring_radius / k, (design.cavity_radius + 1.0) / k, k).copy()
    else:
        img = np.empty((h, w, 3), np.float32)
        img[:] = CAVITY_BGR
    block = design.coil.outer_diameter / k
    if (blocks or wires) and shown.any():
        import cv2

        # one anti-aliased layer per kind, blended once (fixed-point coordinates: 4 fractional bits)
        layers = {"blocks": np.zeros((h, w), np.uint8), "wires": np.zeros((h, w), np.uint8)}
        for p in pts[shown]:
            ang = math.atan2(p[1] - centre[1], p[0] - centre[0])
            c, s = math.cos(ang), math.sin(ang)
            if blocks:
                poly = cv2.boxPoints(((float(p[0]), float(p[1])), (block, block), math.degrees(ang)))
                cv2.fillConvexPoly(layers["blocks"], np.round(poly * 16).astype(np.int32), 255, cv2.LINE_AA, shift=4)
            if wires:
                for side in (-1.0, 1.0):
                    # leave the block's outer face at +-1/4 of its width, run outward, bend a little
                    q0 = np.array([p[0] + c * block / 2 - s * side * block / 4, p[1] + s * block / 2 + c * side * block / 4])
                    q1 = q0 + np.array([c, s]) * 2.0 * block + np.array([-s, c]) * side * 0.5 * block
                    cv2.line(layers["wires"], tuple(int(v) for v in np.round(q0 * 16)),
                             tuple(int(v) for v in np.round(q1 * 16)), 255, 3, cv2.LINE_AA, shift=4)
        for name, bgr in (("blocks", BLOCK_BGR), ("wires", WIRE_BGR)):
            ys, xs = np.nonzero(layers[name])
            if ys.size:
                a = layers[name][ys, xs].astype(np.float32)[:, None] / 255.0
                img[ys, xs] += a * (np.asarray(bgr, np.float32) - img[ys, xs])
    if blur_px <= 0:   # a sharp image: the markers' pixel coverage, drawn before the light
        for p in pts[shown]:
            y0, x0, cov = _disc_coverage(h, w, p[0], p[1], r_m)
            _blend(img, y0, x0, cov.astype(np.float32), marker_bgr)
    gain = None
    if light_gradient or vignette:
        xs = (np.arange(w, dtype=np.float32) - (w - 1) / 2) / w
        ys = (np.arange(h, dtype=np.float32) - (h - 1) / 2) / w
        gain = 1.0 + light_gradient * (xs[None, :] + 0.5 * ys[:, None])
        gain = np.clip(gain * (1.0 - vignette * 2.0 * (xs[None, :] ** 2 + ys[:, None] ** 2)), 0.05, None)
        img *= gain[..., None]
    if blur_px > 0:
        import cv2

        img = cv2.GaussianBlur(img, (0, 0), float(blur_px))
        # markers: blurred before pixel sampling (module doc), over the blurred background; they sit
        # on the uniform coil block, so compositing after the background's blur is the same image
        bgr = np.asarray(marker_bgr, dtype=np.float32)
        for p in pts[shown]:
            y0, x0, a = _blurred_disc_alpha(h, w, p[0], p[1], r_m, float(blur_px))
            col = bgr if gain is None else gain[y0:y0 + a.shape[0], x0:x0 + a.shape[1], None] * bgr
            _blend(img, y0, x0, a, col)
    if noise_sigma > 0:
        img += float(noise_sigma) * rng.standard_normal(img.shape, dtype=np.float32)
    return np.clip(np.rint(img), 0, 255).astype(np.uint8)


def scene_markers(design, tilt_deg=0.0, azimuth_deg=None, *, mtx=None, dist=None,
                  offset_px=(0.0, 0.0)) -> np.ndarray:
    """Marker pixels (N, 2) for whiskers tilted by `tilt_deg` (retraction by default), plus an offset."""
    xyz = geometry.tilted_marker_xyz(design, tilt_deg, azimuth_deg)
    return marker_pixels(design, xyz, mtx=mtx, dist=dist) + np.asarray(offset_px, dtype=float)


def design_sense(design) -> int:
    """Numbering sense of a design's markers in its camera image (rest positions through
    `whisker.vision.render.marker_pixels`)."""
    from whisker.vision.geometry import sense_from_positions

    a = np.radians(design.whisker_angles_deg)
    r = design.whiskers.ring_radius
    xyz = np.stack([r * np.cos(a), r * np.sin(a), np.full_like(a, design.marker_z)], axis=1)
    return sense_from_positions(marker_pixels(design, xyz))
