"""Lens calibration from ChArUco views (OpenCV's aruco module), and the board it needs.

Pipeline (``whisker calibrate camera``):

1. ``board_for(design)``: a ChArUco board whose squares are ``SQUARE_PX`` pixels at the design's
   camera distance (``design.mm_per_px``) and which covers ``BOARD_COVER`` x the field of view at the
   marker plane, so one frame of the board at that plane fills the image.
2. ``detect(spec, image)``: ``cv2.aruco.CharucoDetector`` -> the board's inner corners seen in a frame
   (subpixel, interpolated from the decoded markers). A view with fewer than ``MIN_CORNERS`` corners
   (board blurred, out of view, partly visible) is refused with the reason.
3. ``calibrate_views``: both OpenCV lens models (whisker.vision.lens) are fitted to the same views,
   ``cv2.fisheye.calibrate`` (equidistant, k1..k4) and ``cv2.calibrateCamera`` with
   ``CALIB_RATIONAL_MODEL`` (k1..k6, p1, p2). Every ``HOLDOUT_EVERY``-th view is held out: each
   model's error is the RMS reprojection error (px) of the held-out views, posed by PnP on the
   model's undistorted points (so the pose uses no intrinsics the held-out view itself fixed).
   The model with the lower held-out error wins and is refitted on every view.

``render_board_view`` draws what a camera with a known lens sees of the board at a known pose
(exact inverse mapping per supersampled pixel, then blur, noise and JPEG): the test data whose
truth is known.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field

import numpy as np

from whisker.vision.lens import Lens, project, undistort_points

SQUARE_PX = 40.0        # px a board square spans at the design's camera distance: a 4x4 ArUco marker at
                        # 0.75 of it has ~5 px cells there, decodable after the lens shrinks the edges
BOARD_COVER = 1.3       # board size / field of view at the marker plane (tilted views still fill the image)
MARKER_FRACTION = 0.75  # ArUco marker side / square side
MIN_CORNERS = 12        # ChArUco corners a view needs to count (fewer: a pose is poorly fixed)
MIN_VIEWS = 10          # usable views the calibration needs (>= 3 held out + 7 to fit 8+4 parameters)
HOLDOUT_EVERY = 4       # every 4th usable view is held out to choose the model
MAX_VIEWS = 80          # more views (a live camera's stream) are thinned evenly: the fit time grows, not its accuracy
DICTIONARIES = ((50, "DICT_4X4_50"), (100, "DICT_4X4_100"), (250, "DICT_4X4_250"), (1000, "DICT_4X4_1000"))


class CalibrationInputError(ValueError):
    """The views cannot calibrate the lens (too few, board not seen ...); one line saying why."""


@dataclass(frozen=True)
class BoardSpec:
    """A ChArUco board: squares_x x squares_y squares of square_mm, markers of marker_mm (mm)."""
    squares_x: int
    squares_y: int
    square_mm: float
    marker_mm: float
    dictionary: str

    @property
    def size_mm(self) -> tuple[float, float]:
        return self.squares_x * self.square_mm, self.squares_y * self.square_mm

    def board(self):
        import cv2

        d = cv2.aruco.getPredefinedDictionary(getattr(cv2.aruco, self.dictionary))
        return cv2.aruco.CharucoBoard((self.squares_x, self.squares_y), self.square_mm, self.marker_mm, d)

    def image(self, px_per_mm: float, margin_mm: float = 0.0) -> np.ndarray:
        """The board as a grey uint8 image at px_per_mm, with a white margin of margin_mm (mm)."""
        w, h = self.size_mm
        m = int(round(margin_mm * px_per_mm))
        size = (int(round(w * px_per_mm)) + 2 * m, int(round(h * px_per_mm)) + 2 * m)
        return self.board().generateImage(size, marginSize=m, borderBits=1)

    def as_dict(self) -> dict:
        return {"squares_x": self.squares_x, "squares_y": self.squares_y, "square_mm": self.square_mm,
                "marker_mm": self.marker_mm, "dictionary": self.dictionary}


def board_for(design, square_px: float = SQUARE_PX, cover: float = BOARD_COVER) -> BoardSpec:
    """The ChArUco board for `design`: squares of `square_px` px at the marker plane (rounded to
    0.1 mm), covering `cover` x the field of view there (design.mm_per_px x image size)."""
    k = design.mm_per_px
    sq = max(round(square_px * k, 1), 0.1)
    nx = max(int(math.ceil(cover * design.camera.width_px * k / sq)), 3)
    ny = max(int(math.ceil(cover * design.camera.height_px * k / sq)), 3)
    markers = (nx * ny) // 2
    name = next((n for cap, n in DICTIONARIES if cap >= markers), None)
    if name is None:
        raise CalibrationInputError(f"a {nx}x{ny} board needs {markers} ArUco markers, more than the largest "
                                    "4x4 dictionary (1000); use larger squares")
    return BoardSpec(nx, ny, sq, round(MARKER_FRACTION * sq, 2), name)


# ---- detection -----------------------------------------------------------------------------------

@dataclass
class View:
    """Board corners found in one frame: pixels (M, 2), board points (M, 3) mm, ids (M,)."""
    name: str
    image_px: np.ndarray
    board_mm: np.ndarray
    ids: np.ndarray


def detect(spec: BoardSpec, image, name: str = "", board=None) -> View | str:
    """The board's corners in `image` (BGR or grey uint8), or one line saying why the view is refused."""
    import cv2

    if image is None or not isinstance(image, np.ndarray) or image.size == 0:
        return "no image (the camera or file returned nothing)"
    gray = cv2.cvtColor(image, cv2.COLOR_BGR2GRAY) if image.ndim == 3 else image
    board = board if board is not None else spec.board()
    corners, ids, _, marker_ids = cv2.aruco.CharucoDetector(board).detectBoard(gray)
    n = 0 if ids is None else len(ids)
    if n == 0:
        found = 0 if marker_ids is None else len(marker_ids)
        return f"board not found ({found} markers decoded: blurred, too dark or out of view)"
    if n < MIN_CORNERS:
        return f"only {n} board corners seen, needs >= {MIN_CORNERS} (board partly visible or blurred)"
    ids = ids.ravel().astype(int)
    obj = np.asarray(board.getChessboardCorners(), dtype=np.float64)[ids]
    return View(name, corners.reshape(-1, 2).astype(np.float64), obj, ids)


# ---- fitting ---------------------------------------------------------------------------------------

def _fit(model: str, views: list[View], size_wh) -> tuple[Lens, float, list, list]:
    """One lens model fitted to `views`: (lens, RMS px over the views, rvecs, tvecs). cv2.error on failure."""
    import cv2

    obj = [v.board_mm.reshape(-1, 1, 3).astype(np.float64) for v in views]
    img = [v.image_px.reshape(-1, 1, 2).astype(np.float64) for v in views]
    crit = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-10)
    if model == "fisheye":
        # OpenCV 4.x keeps the fisheye flags in cv2.fisheye, OpenCV 5 in cv2 (with other values)
        flags = 0
        for name in ("CALIB_RECOMPUTE_EXTRINSIC", "CALIB_FIX_SKEW"):
            flags |= getattr(cv2.fisheye, name, None) or getattr(cv2, name)
        rms, K, D, rv, tv = cv2.fisheye.calibrate([o.reshape(1, -1, 3) for o in obj], [i.reshape(1, -1, 2) for i in img], tuple(size_wh),
                                                  np.zeros((3, 3)), np.zeros((4, 1)), flags=flags, criteria=crit)
        lens = Lens(K, np.asarray(D).ravel()[:4], "fisheye", tuple(size_wh))
    else:
        rms, K, D, rv, tv = cv2.calibrateCamera([o.reshape(-1, 3).astype(np.float32) for o in obj],
                                                [i.reshape(-1, 2).astype(np.float32) for i in img],
                                                tuple(size_wh), None, None, flags=cv2.CALIB_RATIONAL_MODEL,
                                                criteria=crit)
        lens = Lens(K, np.asarray(D).ravel(), "rational", tuple(size_wh))
    if not (np.isfinite(rms) and np.all(np.isfinite(lens.mtx)) and np.all(np.isfinite(lens.dist))):
        raise cv2.error("non-finite calibration result")
    return lens, float(rms), list(rv), list(tv)


def pose(lens: Lens, view: View):
    """(rvec, tvec) of the board in `view`: PnP on the lens-undistorted (normalized) corners."""
    import cv2

    norm = undistort_points(lens, view.image_px)
    ok, rvec, tvec = cv2.solvePnP(view.board_mm.astype(np.float64), norm.reshape(-1, 1, 2), np.eye(3), None,
                                  flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        raise cv2.error("solvePnP failed")
    return rvec, tvec


def view_error_px(lens: Lens, view: View) -> float:
    """RMS reprojection error (px) of one view after posing the board with `pose`."""
    rvec, tvec = pose(lens, view)
    d = project(lens, view.board_mm, rvec, tvec) - view.image_px
    return float(np.sqrt(np.mean(np.sum(d * d, axis=1))))


@dataclass
class CameraCalibration:
    lens: Lens
    rms_fit_px: float                    # RMS over every view, chosen model refitted on all of them
    heldout_px: dict                     # model -> held-out RMS px (inf when the model failed to fit)
    views: list[View]
    rejected: list[tuple[str, str]] = field(default_factory=list)
    failures: dict = field(default_factory=dict)   # model -> why it could not be fitted

    def summary(self) -> dict:
        return {"model": self.lens.model, "rms_fit_px": self.rms_fit_px,
                "heldout_rms_px": {m: (e if math.isfinite(e) else None) for m, e in self.heldout_px.items()},
                "views_used": len(self.views), "views_rejected": len(self.rejected),
                "fx_px": float(self.lens.mtx[0, 0]), "fy_px": float(self.lens.mtx[1, 1]),
                "cx_px": float(self.lens.mtx[0, 2]), "cy_px": float(self.lens.mtx[1, 2]),
                "dist": self.lens.dist.tolist(), "image_size": list(self.lens.image_size or ()),
                "model_failures": self.failures}


def calibrate_views(views: list[View], size_wh, rejected=(), models=("fisheye", "rational")) -> CameraCalibration:
    """Fit every model on the kept views, choose by held-out error, refit the winner on all views."""
    import cv2

    if len(views) < MIN_VIEWS:
        why = f"; {len(rejected)} refused, e.g. {rejected[0][0]}: {rejected[0][1]}" if rejected else ""
        raise CalibrationInputError(f"only {len(views)} usable board view(s), needs >= {MIN_VIEWS} "
                                    f"(board at different tilts and places in the image){why}")
    if len(views) > MAX_VIEWS:
        views = [views[i] for i in np.linspace(0, len(views) - 1, MAX_VIEWS).round().astype(int)]
    test = views[HOLDOUT_EVERY - 1::HOLDOUT_EVERY]
    train = [v for i, v in enumerate(views) if (i + 1) % HOLDOUT_EVERY]
    held, failures = {}, {}
    for m in models:
        try:
            lens = _fit(m, train, size_wh)[0]
            errs = [view_error_px(lens, v) for v in test]
            held[m] = float(np.sqrt(np.mean(np.square(errs))))
            if not math.isfinite(held[m]):
                raise cv2.error("non-finite held-out error")
        except cv2.error as err:
            held[m] = math.inf
            failures[m] = str(err).strip().splitlines()[-1][:160]
    best = min(models, key=lambda m: held[m])
    if not math.isfinite(held[best]):
        raise CalibrationInputError("no lens model could be fitted to the views (" +
                                    "; ".join(f"{m}: {e}" for m, e in failures.items()) + ")")
    try:
        lens, rms, _, _ = _fit(best, views, size_wh)
    except cv2.error as err:
        raise CalibrationInputError(f"{best} model failed on all views: {str(err).strip().splitlines()[-1]}") from None
    return CameraCalibration(lens, rms, held, views, list(rejected), failures)


# ---- synthetic views (tests, demos) ---------------------------------------------------------------

def board_pose(spec: BoardSpec, distance_mm: float, tilt_deg: float, tilt_axis_deg: float, spin_deg: float,
               offset_mm=(0.0, 0.0)):
    """(rvec, tvec) of a board whose centre sits at (offset, distance) in the camera frame, turned by
    spin_deg about the optical axis and tilted by tilt_deg about an in-plane axis at tilt_axis_deg."""
    import cv2

    a = math.radians(tilt_axis_deg)
    r_tilt, _ = cv2.Rodrigues(np.array([math.cos(a), math.sin(a), 0.0]) * math.radians(tilt_deg))
    r_spin, _ = cv2.Rodrigues(np.array([0.0, 0.0, math.radians(spin_deg)]))
    R = r_tilt @ r_spin
    w, h = spec.size_mm
    t = np.array([offset_mm[0], offset_mm[1], distance_mm]) - R @ np.array([w / 2, h / 2, 0.0])
    return cv2.Rodrigues(R)[0].ravel(), t


def random_poses(spec: BoardSpec, n: int, distance_mm: float, rng, max_tilt_deg: float = 40.0,
                 offset_mm: float = 6.0) -> list:
    """`n` varied board poses around `distance_mm` (what a person waving the board does)."""
    out = []
    for i in range(n):
        tilt = max_tilt_deg * (0.3 + 0.7 * rng.random()) if i else 0.0
        out.append(board_pose(spec, distance_mm * rng.uniform(0.85, 1.25), tilt, rng.uniform(0, 360),
                              rng.uniform(-25, 25), rng.uniform(-offset_mm, offset_mm, 2)))
    return out


def render_board_view(spec: BoardSpec, lens: Lens, rvec, tvec, size_wh, *, supersample: int = 2,
                      px_per_mm: float = 40.0, noise_sigma: float = 2.0, blur_px: float = 0.6,
                      jpeg_quality: int = 90, seed: int = 0, background: float = 110.0) -> np.ndarray:
    """What `lens` sees of the board at pose (rvec, tvec): BGR uint8 (H, W, 3).

    Each supersampled pixel's ray (the lens model inverted by ``undistort_points``) is intersected
    with the board plane through the plane's homography and the board image is sampled there; the
    supersampled frame is averaged down (INTER_AREA), blurred, given Gaussian noise and JPEG-coded.
    """
    import cv2

    w, h = size_wh
    s = int(supersample)
    margin = spec.square_mm
    board = spec.image(px_per_mm, margin_mm=margin).astype(np.float32) * (180.0 / 255.0) + 40.0
    u = (np.arange(w * s) + 0.5) / s - 0.5
    v = (np.arange(h * s) + 0.5) / s - 0.5
    uu, vv = np.meshgrid(u, v)
    norm = undistort_points(lens, np.column_stack([uu.ravel(), vv.ravel()]))
    R, _ = cv2.Rodrigues(np.asarray(rvec, dtype=np.float64))
    H = np.column_stack([R[:, 0], R[:, 1], np.asarray(tvec, dtype=np.float64).ravel()])
    q = np.column_stack([norm, np.ones(len(norm))]) @ np.linalg.inv(H).T
    with np.errstate(divide="ignore", invalid="ignore"):
        X, Y = q[:, 0] / q[:, 2], q[:, 1] / q[:, 2]
    behind = ~(q[:, 2] > 0) | ~np.isfinite(X) | ~np.isfinite(Y)   # the plane is behind this ray
    mx = (X + margin) * px_per_mm - 0.5     # board pixel centres at integer coordinates (OpenCV)
    my = (Y + margin) * px_per_mm - 0.5
    mx[behind] = -1e6
    my[behind] = -1e6
    # pre-blur the board so that one supersampled frame pixel averages its footprint (no aliasing)
    board = cv2.GaussianBlur(board, (0, 0), 0.5 * px_per_mm * spec.square_mm / SQUARE_PX / s + 0.3)
    big = cv2.remap(board, mx.reshape(h * s, w * s).astype(np.float32), my.reshape(h * s, w * s).astype(np.float32),
                    cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=float(background))
    img = cv2.resize(big, (w, h), interpolation=cv2.INTER_AREA)
    if blur_px > 0:
        img = cv2.GaussianBlur(img, (0, 0), float(blur_px))
    rng = np.random.default_rng(seed)
    if noise_sigma > 0:
        img = img + float(noise_sigma) * rng.standard_normal(img.shape).astype(np.float32)
    img = np.clip(np.rint(img), 0, 255).astype(np.uint8)
    bgr = cv2.cvtColor(img, cv2.COLOR_GRAY2BGR)
    if jpeg_quality:
        ok, buf = cv2.imencode(".jpg", bgr, [cv2.IMWRITE_JPEG_QUALITY, int(jpeg_quality)])
        bgr = cv2.imdecode(buf, cv2.IMREAD_COLOR)
    return bgr


# ---- report ----------------------------------------------------------------------------------------

def plane_mm_per_px(lens: Lens, view: View) -> tuple[float, float]:
    """(distance mm, mm per px) of a board view: the board's distance along the optical axis from its
    pose, and distance / f, the mm per (undistorted) pixel on that plane near the image centre."""
    rvec, tvec = pose(lens, view)
    import cv2

    R, _ = cv2.Rodrigues(rvec)
    centre = R @ np.append(np.mean(view.board_mm[:, :2], axis=0), 0.0) + np.ravel(tvec)
    z = float(centre[2])
    return z, z / float(np.sqrt(lens.mtx[0, 0] * lens.mtx[1, 1]))


def camera_report(cal: CameraCalibration, design, plane_view: View | None = None) -> dict:
    """Numbers a person checks after a lens calibration (JSON-ready, units in the keys)."""
    from whisker.vision.lens import field_of_view_deg

    lens = cal.lens
    f = float(np.sqrt(lens.mtx[0, 0] * lens.mtx[1, 1]))
    out = cal.summary()
    out["field_of_view_deg"] = field_of_view_deg(lens, lens.image_size)
    out["mm_per_px"] = {
        "design": design.mm_per_px,
        "at_design_distance": design.camera.distance / f,
        "design_distance_mm": design.camera.distance,
        "note": "mm per undistorted px at the marker plane; 'at_design_distance' = camera.distance / measured f",
    }
    out["mm_per_px"]["difference_pct"] = 100.0 * (out["mm_per_px"]["at_design_distance"] / design.mm_per_px - 1.0)
    if plane_view is not None:
        z, k = plane_mm_per_px(lens, plane_view)
        out["mm_per_px"].update(plane_view_distance_mm=z, plane_view=k,
                                plane_view_difference_pct=100.0 * (k / design.mm_per_px - 1.0))
    out["rejected"] = [{"view": n, "reason": r} for n, r in cal.rejected]
    return out


def before_after(lens: Lens, image) -> np.ndarray:
    """One frame and the same frame undistorted onto the lens's pinhole, side by side (BGR)."""
    import cv2

    from whisker.vision.lens import undistort_image

    after = undistort_image(lens, image)
    pair = np.concatenate([image, np.full((image.shape[0], 8, 3), 255, np.uint8), after], axis=1)
    for x, text in ((10, "raw"), (image.shape[1] + 18, f"undistorted ({lens.model})")):
        cv2.putText(pair, text, (x, 24), cv2.FONT_HERSHEY_SIMPLEX, 0.7, (0, 0, 255), 2)
    return pair


def board_files(spec: BoardSpec, folder, dpi: int = 600) -> list[str]:
    """Write charuco_board.png (at `dpi`), charuco_board.pdf (true scale on A4, with a 10 mm scale bar
    to check the printer did not scale it) and charuco_board.json (the spec) into `folder`; names."""
    import cv2
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from pathlib import Path

    folder = Path(folder)
    ppmm = dpi / 25.4
    img = spec.image(ppmm, margin_mm=spec.square_mm)
    ok, png = cv2.imencode(".png", img)
    (folder / "charuco_board.png").write_bytes(png.tobytes())
    w, h = spec.size_mm
    m = spec.square_mm
    page_w, page_h = 210.0, 297.0   # A4, mm
    if w + 2 * m > page_w - 20 or h + 2 * m > page_h - 40:
        page_w, page_h = max(page_w, w + 2 * m + 20), max(page_h, h + 2 * m + 40)
    fig = plt.figure(figsize=(page_w / 25.4, page_h / 25.4), dpi=dpi)
    x0, y0 = (page_w - w - 2 * m) / 2, page_h - 20 - (h + 2 * m)
    ax = fig.add_axes((x0 / page_w, y0 / page_h, (w + 2 * m) / page_w, (h + 2 * m) / page_h))
    ax.imshow(img, cmap="gray", vmin=0, vmax=255, interpolation="nearest", extent=(0, w + 2 * m, h + 2 * m, 0),
              aspect="auto")
    ax.set_axis_off()
    bar = fig.add_axes((x0 / page_w, (y0 - 12) / page_h, 10 / page_w, 2 / page_h))
    bar.add_patch(plt.Rectangle((0, 0), 1, 1, color="black"))
    bar.set_xlim(0, 1)
    bar.set_ylim(0, 1)
    bar.set_axis_off()
    fig.text(x0 / page_w, (y0 - 22) / page_h,
             f"10 mm scale bar above. ChArUco {spec.squares_x}x{spec.squares_y}, squares {spec.square_mm:g} mm, "
             f"markers {spec.marker_mm:g} mm, {spec.dictionary}. Print at 100 % (actual size), glue flat.",
             fontsize=7)
    fig.savefig(folder / "charuco_board.pdf", dpi=dpi)   # image placed to 1/dpi inch
    plt.close(fig)
    (folder / "charuco_board.json").write_text(json.dumps(spec.as_dict(), indent=2) + "\n")
    return ["charuco_board.png", "charuco_board.pdf", "charuco_board.json"]


#: the lens `synthetic_board_views` renders with: a fisheye near the authors' (f ~ 349 px), principal point
#: off the image centre; a trial of `whisker calibrate camera --source synthetic-board` should recover it
DEMO_LENS = Lens(np.array([[352.0, 0.0, 326.4], [0.0, 350.6, 236.3], [0.0, 0.0, 1.0]]),
                 np.array([0.031, -0.012, 0.004, -0.0009]), "fisheye", (640, 480))


def synthetic_board_views(design, count: int = 18, seed: int = 7, lens: Lens = DEMO_LENS):
    """`count` JPEG-coded, noisy views of the design's board through `lens` at random poses (BGR)."""
    spec = board_for(design)
    rng = np.random.default_rng(seed)
    size = (design.camera.width_px, design.camera.height_px)
    return [render_board_view(spec, lens, r, t, size, seed=i, noise_sigma=2.0, jpeg_quality=85)
            for i, (r, t) in enumerate(random_poses(spec, count, design.camera.distance, rng))]
