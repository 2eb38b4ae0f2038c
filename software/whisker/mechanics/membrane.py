"""The membrane's rotational stiffness per whisker, from the cast geometry and the silicone's data.

The cast membrane (``membrane.sides``-gon, ``membrane.inscribed_radius``, ``membrane.thickness``)
carries ``whiskers.count`` rods (``whiskers.rod_diameter``) on ``whiskers.ring_radius``, each cast
through its full thickness (the bonded length is the thickness: the rod stands on its stop in the
mould, whisker.cad.solids.mold). Its lower face is glued on the mount's seat ledge outside the seat's
opening (``Design.neck_radius``), which is where it is held. The silicone is the design's
``membrane.material`` (hw/materials/, whisker.mechanics.materials): the small-strain limit of its
neo-Hookean fit.

The finite-element model (whisker.mechanics.fem: scikit-fem, P2-P1 mixed tetrahedra over a Triangle
mesh) gives the 6N x 6N stiffness of the rods' rigid-body motions. For each whisker the tilt is the
rotation about the tangential axis through its pivot, **retraction positive** (tip in, coil out: as
whisker.coil). Condensing every other rod motion (translations, twist, sideways tilt: the rods are
free in them) leaves the N x N tilt stiffness matrix K (N mm/rad): a moment vector M (N mm) gives
the tilts theta = K^-1 M. Its diagonal couples neighbours through the one-piece membrane.

- :func:`stiffness_matrix` (design) -> K, cached on disk per membrane key (below);
- :func:`rotational_stiffness_Nmm_per_rad` (design) -> the per-whisker stiffness the coil model
  uses: every whisker driven by the same moment (the grasp, `whisker calibrate stiffness`'s voltage
  steps, the authors' actuated frame), the mean row sum of K;
  :func:`single_whisker_stiffness_Nmm_per_rad` one whisker alone, 1 / mean(diag(K^-1));
  :func:`driven_stiffness_Nmm_per_rad` any subset; :func:`coupling` the neighbours' tilts;
- :func:`design_stiffness_Nmm_per_rad` (design) -> ``mechanics.rotational_stiffness`` resolved (the
  number in the file, or the model's for "auto"): what every module reads;
- :func:`tilt_stiffness` (explicit geometry, moduli, mesh size) -> uncached, for the tolerance study.
  For this linear model K is exactly proportional to the shear modulus at a fixed K/mu (and within
  0.2 % at a fixed bulk modulus while K >> mu), so a modulus scatter scales K: k(mu') = k(mu) mu'/mu.

Cache: ``$XDG_CACHE_HOME/whisker/membrane/<key>.json`` (default ~/.cache/whisker), the key a digest
of exactly what the model reads (the membrane's geometry, the rods, the clamp radius, the moduli, the
mesh and :data:`MODEL_VERSION`); other design values (coil, camera, drive ...) do not change it. The
default design's entries ship in ``hw/materials/membrane_stiffness.json`` (``make membrane``), so the
core install resolves the default design without the [fem] extra; any other geometry needs it once.

Units: mm, N, MPa, rad.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
import time
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from whisker.mechanics.materials import MaterialError, silicone_for

if TYPE_CHECKING:  # pragma: no cover
    from whisker.design import Design

#: Bump when the model changes what it computes: old cache entries are then ignored.
MODEL_VERSION = 1
#: Default mesh: largest triangle edge, mm (the knee of benchmarks/results/membrane.md).
DEFAULT_MESH_SIZE_MM = 2.5
#: The rods' circles are cut into segments of mesh_size / ROD_REFINEMENT (grades the mesh to the rods).
ROD_REFINEMENT = 4.0
#: The thinnest layer: layers are at most this many times thinner than the rods' segments.
MAX_LAYER_ASPECT = 20.0
SHIPPED_NAME = "membrane_stiffness.json"


class MembraneError(ValueError):
    """A membrane the model cannot compute; one line naming the value."""


@dataclass(frozen=True)
class MembraneGeometry:
    """What the model reads from a design, mm and deg."""

    sides: int
    inscribed_radius: float
    thickness: float
    clamp_radius: float               # the seat's opening: the lower face is glued outside it
    ring_radius: float
    rod_diameter: float
    angles_deg: tuple[float, ...]     # whisker angles from +x, counter-clockwise seen from above

    @classmethod
    def from_design(cls, d: "Design") -> "MembraneGeometry":
        return cls(sides=d.membrane.sides, inscribed_radius=float(d.membrane.inscribed_radius),
                   thickness=d.membrane.thickness, clamp_radius=float(d.neck_radius),
                   ring_radius=d.whiskers.ring_radius, rod_diameter=d.whiskers.rod_diameter,
                   angles_deg=tuple(round(a, 9) for a in d.whisker_angles_deg))

    def outline(self) -> tuple[tuple[float, float], ...]:
        """The polygon's corners, a flat facing +x (as the mould and the seat), mm."""
        rc = self.inscribed_radius / math.cos(math.pi / self.sides)
        return tuple((rc * math.cos(math.pi * (2 * i + 1) / self.sides), rc * math.sin(math.pi * (2 * i + 1) / self.sides))
                     for i in range(self.sides))


def mesh_layers(thickness: float, mesh_size: float) -> int:
    """Prism layers through the thickness: one per half mesh size, at least two (bending), so refining
    the mesh refines through the thickness too."""
    return max(2, math.ceil(2 * thickness / mesh_size - 1e-9))


def check_geometry(g: MembraneGeometry, mesh_size: float, layers: int | None = None) -> None:
    """One line for a membrane the mesher cannot take (too thin, rods outside the seat's opening ...)."""
    rod_seg = mesh_size / ROD_REFINEMENT
    layers = layers or mesh_layers(g.thickness, mesh_size)
    if not all(math.isfinite(v) and v > 0 for v in (g.thickness, g.inscribed_radius, g.rod_diameter, mesh_size)):
        raise MembraneError("membrane model: thickness, radius, rod diameter and mesh size must be positive numbers")
    if g.thickness / layers * MAX_LAYER_ASPECT < rod_seg:
        raise MembraneError(f"membrane.thickness = {g.thickness:g} mm is too thin to mesh: its layers would be more "
                            f"than {MAX_LAYER_ASPECT:g}x thinner than the {rod_seg:.3g} mm elements at the rods "
                            f"(needs >= {rod_seg * layers / MAX_LAYER_ASPECT:.3g} mm at mesh size {mesh_size:g} mm)")
    r_rod = g.rod_diameter / 2
    if g.ring_radius + r_rod >= g.clamp_radius:
        raise MembraneError(f"whiskers.ring_radius + rod radius ({g.ring_radius + r_rod:g} mm) reaches the seat's "
                            f"opening ({g.clamp_radius:g} mm): the rods would stand on the glued rim")
    if g.clamp_radius >= g.inscribed_radius:
        raise MembraneError(f"the seat's opening ({g.clamp_radius:g} mm) must lie inside the membrane "
                            f"(membrane.inscribed_radius {g.inscribed_radius:g} mm)")
    n = len(g.angles_deg)
    if n > 1 and 2 * g.ring_radius * math.sin(math.pi / n) <= g.rod_diameter + rod_seg:
        raise MembraneError(f"{n} rods of {g.rod_diameter:g} mm on a {g.ring_radius:g} mm ring touch each other")


def _retract_axis(angle_deg: float) -> np.ndarray:
    """Rotation axis of a retraction (tip in, coil out) for the whisker at angle_deg: -tangential."""
    a = math.radians(angle_deg)
    return np.array([math.sin(a), -math.cos(a), 0.0])


@dataclass(frozen=True)
class TiltStiffness:
    """The model's answer for one geometry, material and mesh (N mm/rad)."""

    matrix: list            # N x N tilt stiffness K (every other rod motion free), N mm/rad
    single_Nmm_per_rad: float      # 1 / mean(diag(K^-1)): one whisker driven, its neighbours free
    all_driven_Nmm_per_rad: float  # mean row sum of K: every whisker driven by the same moment
    dofs: int
    elements: int
    seconds: float
    mesh_size_mm: float
    layers: int

    @property
    def K(self) -> np.ndarray:
        return np.array(self.matrix)


def tilt_stiffness(geometry: MembraneGeometry, shear_modulus_MPa: float, bulk_modulus_MPa: float,
                   mesh_size_mm: float = DEFAULT_MESH_SIZE_MM, layers: int | None = None) -> TiltStiffness:
    """The FEM, uncached: the tilt stiffness of every whisker of a membrane, N mm/rad.

    Linear in the modulus: k(c mu, c K) = c k(mu, K) exactly; at a fixed K >> mu, k is proportional
    to mu within 0.2 % for a doubling (tests/test_membrane.py). The tolerance study varies the modulus
    by scaling, the thickness by calling this with another geometry (10-45 s per call at the default
    mesh on 2 cores; a coarser mesh_size_mm is cheaper). layers: prism layers through the thickness
    (default :func:`mesh_layers`).
    """
    from whisker.mechanics.fem import Inclusion, MeshError, Plate, solve

    if not (math.isfinite(shear_modulus_MPa) and shear_modulus_MPa > 0
            and math.isfinite(bulk_modulus_MPa) and bulk_modulus_MPa > shear_modulus_MPa):
        raise MembraneError(f"membrane model: need 0 < shear modulus ({shear_modulus_MPa!r} MPa) < bulk modulus "
                            f"({bulk_modulus_MPa!r} MPa)")
    check_geometry(geometry, mesh_size_mm, layers)
    r = geometry.ring_radius
    rods = tuple(Inclusion(r * math.cos(math.radians(a)), r * math.sin(math.radians(a)), geometry.rod_diameter / 2)
                 for a in geometry.angles_deg)
    plate = Plate(geometry.outline(), geometry.thickness, rods, geometry.clamp_radius)
    layers = layers or mesh_layers(geometry.thickness, mesh_size_mm)
    t0 = time.perf_counter()
    try:
        sol = solve(plate, shear_modulus_MPa, bulk_modulus_MPa, mesh_size_mm, mesh_size_mm / ROD_REFINEMENT, layers,
                    axes=[_retract_axis(a) for a in geometry.angles_deg])
    except MeshError as err:
        raise MembraneError(f"membrane model: {err}") from None
    cond = sol.stiffness
    single = 1.0 / float(np.mean(np.diag(np.linalg.inv(cond))))
    return TiltStiffness(matrix=cond.tolist(), single_Nmm_per_rad=single,
                         all_driven_Nmm_per_rad=float(np.mean(cond.sum(axis=1))), dofs=sol.dofs,
                         elements=sol.elements, seconds=time.perf_counter() - t0, mesh_size_mm=mesh_size_mm,
                         layers=layers)


# ---- cache -----------------------------------------------------------------------------------

def cache_dir() -> Path:
    """$XDG_CACHE_HOME/whisker/membrane (default ~/.cache/whisker/membrane)."""
    base = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    return base / "whisker" / "membrane"


def shipped_path() -> Path:
    from whisker.resources import hw_dir
    return hw_dir() / "materials" / SHIPPED_NAME


def model_inputs(d: "Design", mesh_size_mm: float = DEFAULT_MESH_SIZE_MM) -> dict:
    """Everything the model reads for a design (the cache key is its digest)."""
    mat = silicone_for(d.membrane.material)
    g = MembraneGeometry.from_design(d)
    return {"model_version": MODEL_VERSION, "geometry": asdict(g),
            "shear_modulus_MPa": round(mat.shear_modulus_MPa, 12), "bulk_modulus_MPa": mat.bulk_modulus_MPa,
            "mesh_size_mm": mesh_size_mm}


def membrane_key(inputs: dict) -> str:
    return hashlib.sha256(json.dumps(inputs, sort_keys=True).encode()).hexdigest()[:16]


def _read_entry(path: Path, key: str) -> dict | None:
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    entry = data.get(key) if "matrix" not in data else data
    return entry if isinstance(entry, dict) and entry.get("key") == key else None


def lookup(d: "Design", mesh_size_mm: float = DEFAULT_MESH_SIZE_MM, compute: bool = True) -> dict:
    """The model's result for a design: from the user cache, the shipped table, or computed (and cached).

    Raises MembraneError (one line) when it is in neither and the [fem] extra is missing.
    """
    from whisker.files import atomic_write_json

    try:
        inputs = model_inputs(d, mesh_size_mm)
    except MaterialError as err:
        raise MembraneError(str(err)) from None
    key = membrane_key(inputs)
    for path in (cache_dir() / f"{key}.json", shipped_path()):
        hit = _read_entry(path, key)
        if hit is not None:
            return hit
    if not compute:
        raise MembraneError(f"no cached membrane stiffness for this geometry ({key})")
    try:
        import skfem  # noqa: F401
        import triangle  # noqa: F401
    except ModuleNotFoundError as err:
        from whisker.extras import install_command
        raise MembraneError(f"mechanics.rotational_stiffness = \"auto\" needs the membrane model for this geometry: "
                            f"{install_command('fem')} (no {err.name}), or give the stiffness as a number "
                            f"(e.g. from `whisker calibrate stiffness`)") from None
    g = MembraneGeometry(**{k: (tuple(v) if k == "angles_deg" else v) for k, v in inputs["geometry"].items()})
    res = tilt_stiffness(g, inputs["shear_modulus_MPa"], inputs["bulk_modulus_MPa"], mesh_size_mm)
    entry = {"key": key, "inputs": inputs, **asdict(res)}
    try:
        atomic_write_json(cache_dir() / f"{key}.json", entry)
    except OSError:  # a read-only home still gets the value, just not cached
        pass
    return entry


_MEMO: dict = {}


def _entry(design: "Design") -> dict:
    """lookup() memoised per design digest within the process (equilibria call it in loops)."""
    key = design.digest()
    if key not in _MEMO:
        _MEMO[key] = lookup(design)
    return _MEMO[key]


def stiffness_matrix(design: "Design") -> np.ndarray:
    """N x N tilt stiffness matrix of the design's membrane (retraction positive), N mm/rad; cached.

    M = K theta: K[i, j] is the moment on whisker i per radian of whisker j, every other rod motion free.
    """
    return np.array(_entry(design)["matrix"])


def driven_stiffness_Nmm_per_rad(design: "Design", driven=None) -> float:
    """Per-whisker stiffness when the whiskers in `driven` (indices; None = all) get the same moment M
    and the others none: M / mean tilt of the driven ones = 1 / mean_i sum_j C[i, j] (i, j driven),
    C = K^-1, N mm/rad."""
    K = stiffness_matrix(design)
    idx = np.arange(len(K)) if driven is None else np.asarray(sorted(set(int(i) for i in driven)), dtype=int)
    if len(idx) == 0 or idx.min() < 0 or idx.max() >= len(K):
        raise MembraneError(f"driven whiskers {driven!r}: indices must be in 0..{len(K) - 1}")
    C = np.linalg.inv(K)
    return float(1.0 / np.mean(C[np.ix_(idx, idx)].sum(axis=1)))


def rotational_stiffness_Nmm_per_rad(design: "Design") -> float:
    """Per-whisker rotational stiffness of the design's membrane, N mm/rad (the model's; cached).

    Every whisker driven by the same moment - the grasp, `whisker calibrate stiffness`'s voltage
    steps and the authors' actuated frame all drive them together: M / theta = mean row sum of K.
    One whisker driven alone meets more resistance (:func:`single_whisker_stiffness_Nmm_per_rad`):
    its neighbours hold it back; driven together the whole inner membrane turns with them.
    """
    return driven_stiffness_Nmm_per_rad(design, None)


def single_whisker_stiffness_Nmm_per_rad(design: "Design") -> float:
    """One whisker driven, its neighbours free and undriven: 1 / mean(diag(K^-1)), N mm/rad."""
    return float(1.0 / np.mean(np.diag(np.linalg.inv(stiffness_matrix(design)))))


def design_stiffness_Nmm_per_rad(design: "Design") -> float:
    """``mechanics.rotational_stiffness`` resolved: the number in the design (a calibration or an
    explicit override), or for "auto" the model's :func:`rotational_stiffness_Nmm_per_rad`, N mm/rad.
    Every module that needs the stiffness reads it through here."""
    v = design.mechanics.rotational_stiffness
    return float(v) if v != "auto" else rotational_stiffness_Nmm_per_rad(design)


def stiffness_source(design: "Design") -> str:
    """Where design_stiffness_Nmm_per_rad's value comes from, for reports."""
    if design.mechanics.rotational_stiffness != "auto":
        return "design file (mechanics.rotational_stiffness)"
    e = _entry(design)
    return (f"membrane model ({e['inputs']['geometry']['thickness']:g} mm {design.membrane.material}, "
            f"mesh {e['mesh_size_mm']:g} mm, key {e['key']})")


def coupling(design: "Design") -> np.ndarray:
    """C[i, j] = tilt of whisker i per tilt of whisker j when only j is driven (C[j, j] = 1)."""
    comp = np.linalg.inv(stiffness_matrix(design))
    return comp / np.diag(comp)[None, :]


def ship(designs, path: Path | None = None, mesh_size_mm: float = DEFAULT_MESH_SIZE_MM) -> Path:
    """Write the shipped table (``make membrane``): the entries of these designs, keyed."""
    from whisker.files import atomic_write_json

    table = {}
    for d in designs:
        e = lookup(d, mesh_size_mm)
        table[e["key"]] = e
    return atomic_write_json(path or shipped_path(), table)


#: The designs whose results ship in hw/materials/membrane_stiffness.json: the default design, and the
#: paper's 16 mm membrane (the comparison row of docs/membrane.md).
SHIPPED_OVERRIDES: tuple[tuple[str, ...], ...] = ((), ("membrane.inscribed_radius=16",))


def main() -> None:  # pragma: no cover - `make membrane`
    """Compute (or read from the cache) and write the shipped table."""
    from whisker.design import default_design

    path = ship([default_design(*o) for o in SHIPPED_OVERRIDES])
    print(f"wrote {path}")


if __name__ == "__main__":  # pragma: no cover
    main()


def rod_bending_stiffness_Nmm2(design) -> float:
    """EI of the whisker's rod, N*mm^2: E (``mechanics.rod_modulus``, GPa -> N/mm^2) x pi d^4 / 64
    (solid round section, d = ``whiskers.rod_diameter``)."""
    d = design.whiskers.rod_diameter
    return design.mechanics.rod_modulus * 1e3 * math.pi * d ** 4 / 64.0
