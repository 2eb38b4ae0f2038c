"""Axial force between a coil and a coaxial disc magnet, at several fidelity levels.

The coil (a thick solenoid: bore radius a1, outer radius a2, length L, N turns, uniform winding) and
the NdFeB disc magnet (radius R, height h, remanence Br, magnetised along the common axis) face each
other across a face-to-face ``gap``. With no iron nearby the force is linear in the coil current,
F = I * k(gap), so every model here returns k = force per ampere (N/A). Sign convention: a positive
k pulls the coil TOWARDS the magnet for a positive (retracting) current; k changes sign only when
the magnet passes the coil's centre (possible when it fits the bore).

Models (``model=``), cheapest first:

``"dipole"``
    Two point dipoles on the axis: F = 3 mu0 m_c m_m / (2 pi d^4), d = centre-to-centre distance,
    m_c = N I pi (a1^2 + a1 a2 + a2^2)/3, m_m = Br V / mu0 (Jackson, Classical Electrodynamics,
    eq. 5.56 for the dipole field). Far-field only; far too high at millimetre gaps.
``"dipole_field"``
    The magnet as a point dipole in the exact on-axis field of the thick coil:
    F = -m_m dBz/dz, Bz of a thick solenoid on its axis in closed form (e.g. Montgomery, Solenoid
    Magnet Design, 1969, eq. 1-7; the z-derivative is taken analytically).
``"filament"``
    Exact for ideal materials: the magnet is replaced by its equivalent surface current
    K = Br/mu0 on its side wall (a sheet of filament loops), the coil by filament loops with
    uniform current density. The flux linkage gives F = 2 pi n I \\int r [A(r, z_far) - A(r, z_near)] dr
    with A the magnet's vector potential; A of each loop is the classical elliptic-integral form
    A_phi = mu0 I / (pi k) sqrt(R/r) [(1 - k^2/2) K(k) - E(k)] (Smythe, Static and Dynamic
    Electricity, 7.10). Gauss-Legendre quadrature with ``nodes`` points over the coil's radius and
    the magnet's height; converges as ``nodes`` grows (see benchmarks/results/magnetics.md).
``"magpylib"``
    The independent reference: magpylib's closed-form field of a cylinder magnet
    (``magpylib.magnet.Cylinder``) acting on the coil modelled as a ``Collection`` of ``Circle`` loops
    (one per Gauss node, carrying its share of the ampere-turns), force from ``magpylib.getFT``.
    Slow (hundreds of ms); for checks and benchmarks.
``"table"``
    The hot-loop path: the converged filament model tabulated once per geometry and interpolated with
    a cubic spline in (log d, log(k d^4)) (smooth, tends to a constant in the dipole far field).
    Outside the tabulated range it falls back to the filament model.

Skipped effects (Principle 3): no iron or eddy currents, the magnet is ideal (mu_r = 1, uniform
polarisation Br, no demagnetisation by the coil), coil and magnet are coaxial (the small tilt of the
coil at 15 deg whisker deflection is ignored).

Units at the API: millimetres, amperes, newtons, tesla.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.special import ellipe, ellipkm1

MU0 = 4e-7 * math.pi  # H/m (the SI value; 1.00000000055 x this since 2019, irrelevant here)

MODELS = ("dipole", "dipole_field", "filament", "magpylib", "table")

#: Gauss nodes per dimension used for the converged reference and the table (see the benchmark).
REFERENCE_NODES = 48
DEFAULT_FILAMENT_NODES = 12
#: Tabulated range of the fast path: centre distance from touching faces out to this gap (mm).
TABLE_MAX_GAP_MM = 60.0
TABLE_POINTS = 96


class MagneticsError(ValueError):
    """Bad geometry or model request; the one-line message names the offending input."""


@dataclass(frozen=True)
class CoilMagnet:
    """Coaxial coil + disc magnet geometry (mm, turns, tesla)."""

    coil_inner_radius: float
    coil_outer_radius: float
    coil_length: float
    turns: float
    magnet_radius: float
    magnet_height: float
    remanence: float

    def __post_init__(self) -> None:
        for name in ("coil_inner_radius", "coil_outer_radius", "coil_length", "turns",
                     "magnet_radius", "magnet_height", "remanence"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v)):
                raise MagneticsError(f"{name} must be a finite number (got {v!r})")
            if name == "coil_inner_radius":
                if v < 0:
                    raise MagneticsError(f"coil_inner_radius must be >= 0 mm (got {v})")
            elif v <= 0:
                raise MagneticsError(f"{name} must be > 0 (got {v})")
        if self.coil_inner_radius >= self.coil_outer_radius:
            raise MagneticsError(
                f"coil_inner_radius ({self.coil_inner_radius} mm) must be smaller than "
                f"coil_outer_radius ({self.coil_outer_radius} mm)")

    @property
    def magnet_fits_bore(self) -> bool:
        return self.magnet_radius < self.coil_inner_radius

    @property
    def min_gap(self) -> float:
        """Smallest allowed face-to-face gap, mm: 0 (touching) unless the magnet fits the bore."""
        return -(self.coil_length + self.magnet_height) if self.magnet_fits_bore else 0.0

    def centre_distance(self, gap_mm):
        """Coil centre to magnet centre along the axis, mm."""
        return self.coil_length / 2.0 + gap_mm + self.magnet_height / 2.0

    @property
    def coil_moment_per_ampere(self) -> float:
        """Magnetic moment of the coil per ampere, A*m^2/A (uniform winding over a1..a2)."""
        a1, a2 = self.coil_inner_radius * 1e-3, self.coil_outer_radius * 1e-3
        return self.turns * math.pi * (a1 * a1 + a1 * a2 + a2 * a2) / 3.0

    @property
    def magnet_moment(self) -> float:
        """Magnetic moment of the magnet, A*m^2 (Br V / mu0)."""
        vol = math.pi * (self.magnet_radius * 1e-3) ** 2 * self.magnet_height * 1e-3
        return self.remanence * vol / MU0


def geometry(design) -> CoilMagnet:
    """The coil-magnet pair of a :class:`whisker.design.Design`."""
    from whisker.design.former import window

    c, m = design.coil, design.magnet
    a1, a2, length = window(design)  # the winding on the bobbin (whisker.design.former)
    return CoilMagnet(a1, a2, length, float(c.turns),
                      m.diameter / 2.0, m.height, m.remanence)


# ---- elliptic-integral kernels -------------------------------------------------------------

def _f_series(m):
    """(1 - m/2) K(m) - E(m) for small m: pi m^2/32 * 2F1(3/2, 3/2; 3; m), 4 terms."""
    return math.pi * m * m / 32.0 * (1.0 + m * (0.75 + m * (75.0 / 128.0 + m * (1225.0 / 2560.0))))


def loop_vector_potential(loop_radius_m, r_m, dz_m):
    """A_phi (T*m per ampere) of a circular filament loop of radius a at (r, dz), vectorised.

    A = mu0/(pi k) sqrt(a/r) [(1 - k^2/2) K(k^2) - E(k^2)],  k^2 = 4 a r / ((a + r)^2 + dz^2).
    m1 = 1 - k^2 is computed directly (no cancellation), K near k^2 = 1 via scipy's ``ellipkm1``;
    small k^2 uses the hypergeometric series. On the loop itself (r = a, dz = 0), where A diverges
    logarithmically, m1 is floored at 1e-300 so the integrable singularity stays finite.
    """
    a = np.asarray(loop_radius_m, dtype=float)
    r = np.asarray(r_m, dtype=float)
    dz = np.asarray(dz_m, dtype=float)
    s = (a + r) ** 2 + dz * dz
    m = 4.0 * a * r / s
    m1 = np.maximum(((a - r) ** 2 + dz * dz) / s, 1e-300)
    small = m < 1e-3
    with np.errstate(invalid="ignore", divide="ignore"):
        f_direct = (1.0 - 0.5 * m) * ellipkm1(m1) - ellipe(np.minimum(m, 1.0))
        f = np.where(small, _f_series(m), f_direct)
        # A = mu0/pi * sqrt(a/r) f / sqrt(m) = mu0/pi * f * sqrt(s) / (2 r)
        out = MU0 / math.pi * f * np.sqrt(s) / (2.0 * np.where(r > 0, r, 1.0))
    return np.where(r > 0, out, 0.0)


# ---- models ---------------------------------------------------------------------------------

def _as_gap(g: CoilMagnet, gap_mm, model: str) -> np.ndarray:
    gap = np.asarray(gap_mm, dtype=float)
    if not np.all(np.isfinite(gap)):
        raise MagneticsError(f"gap_mm must be finite (got {gap_mm!r})")
    lo = g.min_gap
    if np.any(gap < lo):
        bad = float(np.min(gap))
        if g.magnet_fits_bore:
            raise MagneticsError(f"gap_mm {bad:g} < {lo:g}: the magnet would have left the coil's far end")
        raise MagneticsError(
            f"gap_mm {bad:g} < 0: the magnet (radius {g.magnet_radius:g} mm) cannot enter the coil "
            f"bore (radius {g.coil_inner_radius:g} mm)")
    return gap


def k_dipole(g: CoilMagnet, gap_mm) -> np.ndarray:
    """Point dipole - point dipole, N/A. Refuses a centre distance of zero (the dipole singularity)."""
    d = g.centre_distance(np.asarray(gap_mm, dtype=float)) * 1e-3
    if np.any(np.abs(d) < 1e-9):
        raise MagneticsError("model 'dipole' is singular where the magnet's centre meets the coil's centre")
    return 3.0 * MU0 * g.coil_moment_per_ampere * g.magnet_moment / (2.0 * math.pi * d ** 4) * np.sign(d)


def coil_axial_field_gradient(g: CoilMagnet, z_mm) -> np.ndarray:
    """dBz/dz (T/m per ampere) on the axis of the thick coil, coil centre at z = 0, closed form.

    Bz = mu0 J/2 [u ln((a2 + sqrt(a2^2+u^2))/(a1 + sqrt(a1^2+u^2)))]_{u = z - L/2}^{u = z + L/2},
    J = N / (L (a2 - a1)) per ampere; d/du[u ln(..)] = ln(..) + u^2 (1/(s2 (a2+s2)) - 1/(s1 (a1+s1))).
    """
    a1, a2, L = g.coil_inner_radius * 1e-3, g.coil_outer_radius * 1e-3, g.coil_length * 1e-3
    z = np.asarray(z_mm, dtype=float) * 1e-3
    J = g.turns / (L * (a2 - a1))

    def h(u):
        s1, s2 = np.sqrt(a1 * a1 + u * u), np.sqrt(a2 * a2 + u * u)
        return np.log((a2 + s2) / (a1 + s1)) + u * u * (1.0 / (s2 * (a2 + s2)) - 1.0 / (s1 * (a1 + s1)))

    return MU0 * J / 2.0 * (h(z + L / 2.0) - h(z - L / 2.0))


def k_dipole_field(g: CoilMagnet, gap_mm) -> np.ndarray:
    """Magnet as a point dipole in the coil's exact on-axis field gradient, N/A."""
    d = g.centre_distance(np.asarray(gap_mm, dtype=float))
    return -g.magnet_moment * coil_axial_field_gradient(g, d)


@functools.lru_cache(maxsize=64)
def _gauss(n: int):
    return np.polynomial.legendre.leggauss(n)


def k_filament(g: CoilMagnet, gap_mm, nodes: int = DEFAULT_FILAMENT_NODES) -> np.ndarray:
    """Filament-loop model (exact for ideal materials as nodes -> inf), N/A, vectorised over gaps.

    Force on the coil per ampere = 2 pi n \\int_{a1}^{a2} r [A_m(r, z2) - A_m(r, z1)] dr with
    n = N / (L (a2 - a1)), z1/z2 the coil's faces and A_m(r, z) = (Br/mu0) \\int_magnet A_loop dz'
    the magnet's vector potential (its equivalent surface current). Gauss-Legendre, `nodes` points
    in r and in z'. Cost: 2 nodes^2 elliptic-integral pairs per gap.
    """
    if not (isinstance(nodes, (int, np.integer)) and nodes >= 1):
        raise MagneticsError(f"nodes must be a positive integer (got {nodes!r})")
    gap = np.asarray(gap_mm, dtype=float)
    a1, a2, L = g.coil_inner_radius * 1e-3, g.coil_outer_radius * 1e-3, g.coil_length * 1e-3
    R, h = g.magnet_radius * 1e-3, g.magnet_height * 1e-3
    x, w = _gauss(int(nodes))
    r = (a1 + a2) / 2.0 + (a2 - a1) / 2.0 * x           # coil radii
    wr = (a2 - a1) / 2.0 * w
    zm0 = L / 2.0 + gap[..., None, None] * 1e-3         # magnet's near face (coil centre at 0)
    zp = zm0 + h / 2.0 * (1.0 + x[None, :])             # magnet sheet nodes
    wz = h / 2.0 * w
    K = g.remanence / MU0                               # A/m, equivalent surface current
    rr = r[:, None]
    a_far = loop_vector_potential(R, rr, L / 2.0 - zp)  # at the coil face nearer the magnet (z = +L/2)
    a_near = loop_vector_potential(R, rr, -L / 2.0 - zp)
    a_diff = K * ((a_far - a_near) * wz).sum(axis=-1)   # A_m(r, +L/2) - A_m(r, -L/2), per node r
    n = g.turns / (L * (a2 - a1))
    return 2.0 * math.pi * n * (a_diff * r * wr).sum(axis=-1)


def k_magpylib(g: CoilMagnet, gap_mm, nodes: int = 12, meshing: int = 64, method: str = "getFT"):
    """The independent reference with magpylib, N/A.

    ``method="getFT"``: ``magpylib.getFT(cylinder, coil)`` with the coil a Collection of Circle
    loops at Gauss nodes (r, z) carrying their share of the ampere-turns, each cut into `meshing`
    segments. ``method="getB"``: magpylib's closed-form B of the cylinder at the same nodes,
    F = -2 pi n \\sum w r B_r (exact for circular loops, no segment meshing).
    """
    import magpylib as magpy

    gaps = np.atleast_1d(np.asarray(gap_mm, dtype=float))
    a1, a2, L = g.coil_inner_radius * 1e-3, g.coil_outer_radius * 1e-3, g.coil_length * 1e-3
    R, h = g.magnet_radius * 1e-3, g.magnet_height * 1e-3
    x, w = _gauss(int(nodes))
    r = (a1 + a2) / 2.0 + (a2 - a1) / 2.0 * x
    wr = (a2 - a1) / 2.0 * w
    zc = L / 2.0 * x
    wz = L / 2.0 * w
    n = g.turns / (L * (a2 - a1))
    out = np.empty(gaps.shape)
    for i, gap in enumerate(gaps):
        zmag = L / 2.0 + gap * 1e-3 + h / 2.0
        magnet = magpy.magnet.Cylinder(position=(0, 0, zmag), dimension=(2 * R, h),
                                       polarization=(0, 0, g.remanence))
        if method == "getB":
            # observers at (r, 0, z): B_x there is B_r
            obs = np.stack(np.broadcast_arrays(r[:, None], 0.0 * r[:, None], zc[None, :]), axis=-1)
            br = magpy.getB(magnet, obs.reshape(-1, 3))[:, 0].reshape(len(r), len(zc))
            out[i] = -2.0 * math.pi * n * np.sum(br * (r * wr)[:, None] * wz[None, :])
        elif method == "getFT":
            loops = [magpy.current.Circle(position=(0, 0, zj), diameter=2 * ri, current=n * wri * wzj)
                     for ri, wri in zip(r, wr) for zj, wzj in zip(zc, wz)]
            coil = magpy.Collection(*loops)
            F, _ = magpy.getFT(magnet, coil, meshing=meshing, pivot=None)
            out[i] = np.asarray(F).reshape(-1)[2]
        else:
            raise MagneticsError(f"magpylib method must be 'getFT' or 'getB' (got {method!r})")
    return out.reshape(np.shape(gap_mm))


class ForceTable:
    """k(gap) tabulated with the converged filament model; cubic spline in (log d, log(k d^4))."""

    def __init__(self, g: CoilMagnet, points: int = TABLE_POINTS, max_gap_mm: float = TABLE_MAX_GAP_MM,
                 nodes: int = REFERENCE_NODES):
        from scipy.interpolate import CubicSpline

        self.geometry = g
        self.gap_lo, self.gap_hi = 0.0, float(max_gap_mm)
        d_lo, d_hi = g.centre_distance(self.gap_lo), g.centre_distance(self.gap_hi)
        # nodes dense near contact: uniform in log(d - d_lo + c) mapped, here simply log d
        t = np.linspace(math.log(d_lo), math.log(d_hi), points)
        d = np.exp(t)
        k = k_filament(g, d - g.centre_distance(0.0), nodes=nodes)
        if np.any(k <= 0):
            raise MagneticsError("force table: the force changes sign inside the table range")
        self._spline = CubicSpline(t, np.log(k) + 4.0 * t)
        self._c = self._spline.c
        self._x = self._spline.x
        self._d0 = g.centre_distance(0.0)

    def __call__(self, gap_mm) -> np.ndarray:
        gap = np.asarray(gap_mm, dtype=float)
        inside = (gap >= self.gap_lo) & (gap <= self.gap_hi)
        t = np.log(np.where(inside, gap, 0.0) + self._d0)
        # Horner on the spline's pieces (what PPoly does, without its call overhead)
        i = np.clip(np.searchsorted(self._x, t, side="right") - 1, 0, len(self._x) - 2)
        dt = t - self._x[i]
        c = self._c
        y = ((c[0, i] * dt + c[1, i]) * dt + c[2, i]) * dt + c[3, i]
        k = np.exp(y - 4.0 * t)
        if np.all(inside):
            return k
        return np.where(inside, k, k_filament(self.geometry, np.where(inside, self.gap_lo, gap),
                                               nodes=REFERENCE_NODES))


@functools.lru_cache(maxsize=32)
def force_table(g: CoilMagnet) -> ForceTable:
    """The cached fast-path table of a geometry (built once, ~0.1 s)."""
    return ForceTable(g)


def k_per_ampere(g: CoilMagnet, gap_mm, model: str = "table", nodes: int | None = None) -> np.ndarray:
    """Force on the coil towards the magnet per ampere (N/A) for a geometry, any model."""
    gap = _as_gap(g, gap_mm, model)
    if model == "table":
        out = force_table(g)(gap)
    elif model == "filament":
        out = k_filament(g, gap, nodes=nodes or DEFAULT_FILAMENT_NODES)
    elif model == "dipole":
        out = k_dipole(g, gap)
    elif model == "dipole_field":
        out = k_dipole_field(g, gap)
    elif model == "magpylib":
        out = k_magpylib(g, gap, nodes=nodes or 12)
    else:
        raise MagneticsError(f"unknown model {model!r}; choose one of {', '.join(MODELS)}")
    out = np.asarray(out, dtype=float)
    if not np.all(np.isfinite(out)):  # pragma: no cover - guarded above; keep the promise explicit
        raise MagneticsError(f"model {model!r} produced a non-finite force for gap_mm={gap_mm!r}")
    return out if out.ndim else out[()]


def force_per_ampere_N(design, gap_mm, model: str = "table", nodes: int | None = None):
    """Radial force on a whisker's coil per ampere of retracting current, N/A, vectorised over gap_mm.

    Positive = towards the magnet (retraction). Models: "dipole", "dipole_field", "filament",
    "magpylib", "table" (the fast path; see the module docstring). ``nodes`` sets the Gauss order of
    "filament"/"magpylib".
    """
    return k_per_ampere(geometry(design), gap_mm, model=model, nodes=nodes)
