"""The camera and tracking effects: simulated frames -> tracker -> geometry, against ground truth.

Built when the scene's camera is on and frames, video or tracks are asked for. Each frame: the
markers' sensor-frame positions (whisker.coil.kinematics) projected by ``whisker.vision.render.marker_pixels``
(the design's pinhole, the lens distortion of the tracker's calibration when given), drawn by
``whisker.vision.render.render_frame`` (coil blocks, red markers, wires, LED ring, noise and blur, seeded
per frame). With ``camera.calibration`` (a lens .npz of any model, whisker.vision.lens: the authors' lens calibration
or one from ``whisker calibrate camera``, standard or fisheye) the frames carry that lens's distortion and the tracker undistorts its centroids.
The tracking effect calibrates a ``whisker.vision.tracking.Tracker`` on rest frames (the
paper's rest baseline), tracks every frame, converts the pixel displacements with the tracker's
geometry (the paper's equations) and compares the tips with the simulator's ground truth.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from whisker.coil.kinematics import marker_positions_mm, tip_positions_mm


@dataclass
class CameraRun:
    t_s: np.ndarray                  # (F,) frame times
    true_px: np.ndarray              # (F, N, 2) projected marker centres
    frames: list | None              # rendered BGR frames when kept
    est_tip_mm: np.ndarray | None    # (F, N, 2) tracked tip displacement (sensor x, y)
    true_tip_mm: np.ndarray | None   # (F, N, 2) ground-truth tip displacement
    valid: np.ndarray | None         # (F, N) tracker valid flags
    tip_rms_mm: float | None
    tip_max_mm: float | None
    px_rms: float | None             # tracked vs projected marker centre, px

    def summary(self) -> dict:
        out = {"frames": int(len(self.t_s))}
        if self.tip_rms_mm is not None:
            out.update(tip_rms_mm=self.tip_rms_mm, tip_max_mm=self.tip_max_mm, marker_rms_px=self.px_rms,
                       valid_fraction=float(np.mean(self.valid)))
        return out


def frame_times(duration: float, fps: float) -> np.ndarray:
    n = int(np.floor(duration * fps + 1e-9)) + 1
    return np.arange(n) / fps


def camera_run(scene, design, result, *, keep_frames: bool = False, track: bool = True,
               rest_frames: int = 5, progress=None) -> CameraRun:
    """Render the result's frames at the scene's fps and (optionally) track them."""
    from pathlib import Path

    from whisker.sim.contract import load_calibration, marker_pixels, render_frame, tracker

    cam = scene.camera
    mtx = dist = None
    model = "standard"
    if cam.calibration:
        p = Path(cam.calibration)
        p = p if p.is_absolute() else Path(scene.base_dir) / p
        from whisker.sim.scene import SceneError
        try:
            mtx, dist, model = load_calibration(p)
        except ValueError as err:
            raise SceneError(f"camera.calibration: {err}") from None
    times = frame_times(float(result.t_s[-1]), cam.fps) if len(result.t_s) > 1 else np.zeros(1)
    idx = np.clip(np.searchsorted(result.t_s, times - 1e-9), 0, len(result.t_s) - 1)
    theta = result.theta_rad[idx]
    n = theta.shape[1]
    px = np.array([marker_pixels(design, marker_positions_mm(design, th), mtx, dist, model) for th in theta])
    rest_px = marker_pixels(design, marker_positions_mm(design, np.zeros((n, 2))), mtx, dist, model)
    seed0 = scene.scene.seed * 100003

    def draw(p, k):
        return render_frame(design, p, seed=seed0 + k, noise_sigma=cam.noise_sigma, blur_px=cam.blur_px)

    frames = [] if keep_frames else None
    est = valid = None
    if track:
        trk = tracker(design, cam.method, None if mtx is None else (mtx, dist, model))
        trk.calibrate([draw(rest_px, 10_000_000 + j) for j in range(rest_frames)])   # own noise seeds
        est = np.full((len(times), n, 2), np.nan)
        valid = np.zeros((len(times), n), bool)
        tracked_px = np.full((len(times), n, 2), np.nan)
    for k in range(len(times)):
        img = draw(px[k], k)
        if frames is not None:
            frames.append(img)
        if track:
            r = trk.track(img)
            g = trk.deflection(r, model=cam.geometry)
            est[k, :, 0], est[k, :, 1] = g.tip_x_mm, g.tip_y_mm
            valid[k] = np.asarray(r.valid) & np.isfinite(g.tip_x_mm)
            tp = getattr(r, "track_px", None)
            tracked_px[k] = r.positions_px if tp is None else tp    # raw (distorted) frame coordinates
        if progress and k % 10 == 0:
            progress(k / len(times))
    if not track:
        return CameraRun(times, px, frames, None, None, None, None, None, None)
    tips = tip_positions_mm(design, theta)[..., :2] - tip_positions_mm(design, np.zeros((n, 2)))[..., :2]
    err = np.linalg.norm(est - tips, axis=-1)
    ok = valid & np.isfinite(err)
    rms = float(np.sqrt(np.mean(err[ok] ** 2))) if ok.any() else float("nan")
    mx = float(err[ok].max()) if ok.any() else float("nan")
    pe = np.linalg.norm(tracked_px - px, axis=-1)
    pok = np.isfinite(pe)
    prms = float(np.sqrt(np.mean(pe[pok] ** 2))) if pok.any() else float("nan")
    return CameraRun(times, px, frames, est, tips, valid, rms, mx, prms)


def video_bytes(frames: list, fps: float) -> bytes:
    """An MP4 (mp4v) of BGR frames, via OpenCV."""
    import os
    import tempfile

    import cv2

    h, w = frames[0].shape[:2]
    with tempfile.TemporaryDirectory() as d:
        p = os.path.join(d, "v.mp4")
        vw = cv2.VideoWriter(p, cv2.VideoWriter_fourcc(*"mp4v"), float(fps), (w, h))
        for f in frames:
            vw.write(f)
        vw.release()
        with open(p, "rb") as fh:
            return fh.read()


def png_frame(img) -> bytes:
    import cv2

    ok, buf = cv2.imencode(".png", img)
    if not ok:
        raise RuntimeError("could not encode a frame as PNG")
    return buf.tobytes()
