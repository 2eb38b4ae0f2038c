"""Subpixel marker centres in small round windows around known positions (the ``roi`` and ``fit``
tracking methods of `whisker.vision.tracking`).

`MarkerWindows.roi`: in a round window of radius marker radius + 5 px around each marker's last
position, the centroid of the redness 2 R - G - B above twice the threshold (all windows in one numpy
gather), re-centred once when the marker may be cut by the window (weight on its rim, or a shift of
more than 1.5 px). `MarkerWindows.refine`: a least-squares fit of a blurred disc to each marker
(Gauss-Newton, all markers at once), the most exact and the slowest. Positions and radii in px of the frame.
"""

from __future__ import annotations

import math

import numpy as np


class MarkerWindows:
    """Windows of one marker size. marker_r: the markers' radius in the frame, px (sets the window
    radius, marker_r + 5 px); edge_r: the radius of the marker's half-contrast edge where the disc fit
    starts, px; threshold: the redness threshold, grey levels (as the blob detector's). `last_fit`:
    (fitted disc radius px, accepted) per marker of the last `refine` call."""

    def __init__(self, marker_r: float, edge_r: float, threshold: int):
        self.marker_r = float(marker_r)
        self.edge_r = float(edge_r)
        self.threshold = int(threshold)
        self.half = int(math.ceil(self.marker_r + 5))  # ROI window radius, px
        self._offs = np.arange(-self.half, self.half + 1, dtype=np.float32)
        rr = np.hypot(self._offs[:, None], self._offs[None, :])
        self._disc = (rr <= self.half + 0.5).astype(np.float32)
        self._rim = ((rr > self.half - 1.5) & (rr <= self.half + 0.5)).astype(np.float32)
        self._fit_geom = None
        self.last_fit = (np.zeros(0), np.zeros(0, bool))

    def windows(self, img, mask, centre):
        """Weighted centroid offsets of square windows centred on integer pixels `centre` (S, 2)."""
        hw = self.half
        offs = self._offs
        # slicing is cheaper than fancy indexing for a handful of windows
        win = np.stack([img[y - hw:y + hw + 1, x - hw:x + hw + 1] for x, y in centre.tolist()])
        win = win.astype(np.int16)
        red = 2 * win[..., 2] - win[..., 0] - win[..., 1]   # 2 x (R - (G + B) / 2): less noisy than R - max(G, B)
        wgt = np.maximum(red - 2 * self.threshold, 0).astype(np.float32)
        wgt *= self._disc  # a round window: the red wires leaving the coil block stay outside
        if mask is not None:
            wgt *= np.stack([mask[y - hw:y + hw + 1, x - hw:x + hw + 1] for x, y in centre.tolist()]) > 0
        col = wgt.sum(axis=1)   # (S, W): weight per x
        row = wgt.sum(axis=2)   # (S, W): weight per y
        m = col.sum(axis=1)
        safe = np.where(m > 0, m, 1.0)
        rim = (wgt * self._rim).sum(axis=(1, 2))
        return (col @ offs) / safe, (row @ offs) / safe, m, rim / safe

    def refine(self, img, mask, xy, iters: int = 2):
        """Least-squares fit of a blurred disc to each marker's redness, started at `xy` (M, 2).

        Model per window: b + a * Phi((rho - |p - p0|) / s) (Phi = standard normal CDF: a disc of
        radius rho with a Gaussian-blurred edge of width s, on a flat background b), parameters
        p0 = (x0, y0), rho, a, b, s, solved by `iters` Gauss-Newton steps (all markers at once).
        Unlike a centroid it weighs each pixel by how much it says about the edge, so noise in the
        flat interior and background does not move it. A marker whose fit fails, moves more than
        1 px or ends with an implausible radius/contrast keeps its starting (centroid) position.
        """
        from scipy.special import ndtr

        h, w = img.shape[:2]
        hw = self.half
        c = np.rint(xy).astype(int)
        ok = (c[:, 0] >= hw) & (c[:, 1] >= hw) & (c[:, 0] < w - hw) & (c[:, 1] < h - hw)
        if not ok.any():
            self.last_fit = (np.full(len(xy), np.nan), np.zeros(len(xy), bool))
            return xy
        disc = self._disc > 0
        if self._fit_geom is None:
            rr = np.hypot(self._offs[:, None], self._offs[None, :])[disc]
            xs = np.broadcast_to(self._offs[None, :], disc.shape)[disc].astype(np.float64)
            ys = np.broadcast_to(self._offs[:, None], disc.shape)[disc].astype(np.float64)
            self._fit_geom = (xs, ys, rr > hw - 1.5, rr < max(self.marker_r - 2.0, 1.0))
        xs, ys, rim, core = self._fit_geom
        cs = c[ok]
        win = np.stack([img[y - hw:y + hw + 1, x - hw:x + hw + 1][disc] for x, y in cs.tolist()]).astype(np.float64)
        R = win[..., 2] - 0.5 * (win[..., 0] + win[..., 1])
        if mask is not None:
            inside = np.stack([mask[y - hw:y + hw + 1, x - hw:x + hw + 1][disc] for x, y in cs.tolist()]) > 0
            full = inside.all(axis=1)  # a window the mask cuts does not fit the model: keep the centroid
        else:
            full = np.ones(len(cs), bool)
        b = R[:, rim].mean(axis=1)
        a = R[:, core].mean(axis=1) - b
        x0 = xy[ok, 0] - cs[:, 0]
        y0 = xy[ok, 1] - cs[:, 1]
        rho = np.full(len(cs), self.edge_r)
        s = np.full(len(cs), 0.9)
        J = np.empty(R.shape + (6,))
        try:
            for _ in range(iters):
                dx = xs - x0[:, None]
                dy = ys - y0[:, None]
                d = np.sqrt(dx * dx + dy * dy) + 1e-9
                u = (rho[:, None] - d) / s[:, None]
                Phi = ndtr(u)
                g = (a / s)[:, None] * np.exp(-0.5 * u * u) * 0.3989422804014327
                res = R - (b[:, None] + a[:, None] * Phi)
                J[..., 0] = g * dx / d
                J[..., 1] = g * dy / d
                J[..., 2] = g
                J[..., 3] = Phi
                J[..., 4] = 1.0
                J[..., 5] = -g * u
                Jt = J.transpose(0, 2, 1)
                step = np.linalg.solve(Jt @ J, Jt @ res[..., None])[..., 0]
                x0, y0 = x0 + step[:, 0], y0 + step[:, 1]
                rho, a, b = rho + step[:, 2], a + step[:, 3], b + step[:, 4]
                s = np.clip(s + step[:, 5], 0.3, 5.0)
        except np.linalg.LinAlgError:
            self.last_fit = (np.full(len(xy), np.nan), np.zeros(len(xy), bool))
            return xy
        new = np.stack([cs[:, 0] + x0, cs[:, 1] + y0], axis=1)
        good = (full & np.all(np.isfinite(new), axis=1) & (np.hypot(*(new - xy[ok]).T) < 1.0)
                & (rho > 0.5 * self.marker_r) & (rho < 2.0 * self.marker_r) & (a > 0))
        out = xy.copy()
        sel = np.flatnonzero(ok)[good]
        out[sel] = new[good]
        radius = np.full(len(xy), np.nan)
        radius[sel] = rho[good]
        accepted = np.zeros(len(xy), bool)
        accepted[sel] = True
        self.last_fit = (radius, accepted)   # fitted disc radius (px) and which markers took the fit
        return out

    def roi(self, img, mask, ref):
        """Windowed weighted centroids around `ref` (N,2). Returns positions, ok flags, masses."""
        h, w = img.shape[:2]
        hw = self.half
        centre = np.rint(ref).astype(int)  # callers pass finite refs
        inside = (centre[:, 0] >= hw) & (centre[:, 1] >= hw) & (centre[:, 0] < w - hw) & (centre[:, 1] < h - hw)
        n = len(ref)
        pos = np.full((n, 2), np.nan)
        mass = np.zeros(n)
        rim = np.ones(n)
        sel = np.flatnonzero(inside)
        for _ in range(2):  # a second pass re-centres the windows of markers near the window's edge
            if sel.size == 0:
                break
            ex, ey, m, r = self.windows(img, mask, centre[sel])
            pos[sel, 0] = centre[sel, 0] + ex
            pos[sel, 1] = centre[sel, 1] + ey
            mass[sel] = m
            rim[sel] = r
            # Re-centre only if the marker may be cut by the window: weight on the rim, or a shift
            # of more than 1.5 px (the window has 5 px of margin around the marker). Otherwise the
            # background weight is zero, the whole marker is inside and the centroid does not
            # depend on where the window sits.
            moved = (m > 0) & ((r > 1e-3) | (ex * ex + ey * ey > 2.25))
            if not moved.any():
                break
            new = np.rint(pos[sel[moved]]).astype(int)
            fits = (new[:, 0] >= hw) & (new[:, 1] >= hw) & (new[:, 0] < w - hw) & (new[:, 1] < h - hw)
            sel = sel[moved][fits]
            centre[sel] = new[fits]
        ok = inside & (mass > 0) & (rim < 0.02)
        return pos, ok, mass
