"""The scene model: what a simulation contains, read from a TOML file and validated.

A scene names the design (file + overrides), the objects on the table, the prescribed path of the
sensor (like the UR16e arm in the paper), the actuation schedule, the camera, the duration, the
outputs wanted and, optionally, an experiment that repeats the scene with variations (the paper's
figures and tables). Every value has a unit in its description; a bad scene is refused with one
line naming the offending key (:class:`SceneError`).

Conventions (see docs/sim.md):
- the sensor frame is the design's frame (z = 0 the membrane's lower face, whiskers along +z);
- the world has the table top at z = 0, z up; ``sensor.facing = "down"`` (the grasp pose) turns the
  sensor so its whiskers point down;
- a path waypoint is ``[t_s, x_mm, y_mm, tip_height_mm, yaw_deg]``: the sensor axis at (x, y), the
  resting whisker tips ``tip_height_mm`` above the table top, the sensor turned ``yaw_deg`` about the
  vertical; between waypoints the pose moves linearly (the arm's linear moves);
- an actuation event ``{t = s, level = l, whiskers = [...]}`` sets the signed duty ``l`` in [-1, 1]
  (+ retracts, tips toward the centre) of the listed whiskers (default all) from time t on; level 1
  is the full-scale coil voltage ``whisker.drive.guard.full_scale_voltage(design)``, the actuation module's
  definition (``drive.full_scale_voltage`` when measured, else the driver model); a scene changes it
  through its design (``[design] set = ["drive.full_scale_voltage=1.0"]``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field, ValidationError, field_validator, model_validator

from whisker.design import one_line_errors, parse_value
from whisker.sim.effects.airflow import AirflowSpec
from whisker.sim.materials import Material
from whisker.files import read_toml


class SceneError(ValueError):
    """A scene that cannot be simulated. The message is one line naming the key(s)."""


class _S(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True, allow_inf_nan=False)


class SceneInfo(_S):
    name: str = "scene"
    description: str = ""
    duration: float = Field(0.0, ge=0, le=3600, description="s of simulated time (0: static)")
    timestep: float = Field(1e-3, gt=0, le=0.05, description="s, integration step")
    seed: int = Field(0, ge=0, description="random seed (placement noise, camera noise)")
    initial_tilt_deg: float = Field(0.0, ge=-45, le=45,
                                    description="deg, radial tilt of every whisker at t = 0 (a pluck)")


class DesignRef(_S):
    file: str = Field("", description="design TOML, relative to the scene file; empty: hw/sensor.toml")
    set: list[str] = Field(default_factory=list, description="section.key=value overrides")


class Sensor(_S):
    facing: Literal["down", "up"] = "down"
    path: list[list[float]] = Field(
        default_factory=lambda: [[0.0, 0.0, 0.0, 20.0, 0.0]],
        description="waypoints [t_s, x_mm, y_mm, tip_height_mm, yaw_deg], times increasing")

    @field_validator("path")
    @classmethod
    def _path(cls, v: list[list[float]]) -> list[list[float]]:
        if not v:
            raise ValueError("needs at least one waypoint [t_s, x_mm, y_mm, tip_height_mm, yaw_deg]")
        for i, w in enumerate(v):
            if len(w) != 5:
                raise ValueError(f"waypoint {i} has {len(w)} values, expected 5 [t, x, y, tip_height, yaw]")
            for name, val, lim in zip(("t_s", "x_mm", "y_mm", "tip_height_mm", "yaw_deg"), w, PATH_LIMITS):
                if not abs(val) <= lim:
                    raise ValueError(f"waypoint {i}: {name} = {val:g} is beyond +-{lim:g}")
        ts = [w[0] for w in v]
        if any(b <= a for a, b in zip(ts, ts[1:])) or ts[0] < 0:
            raise ValueError(f"waypoint times must start at >= 0 and increase strictly (got {ts})")
        return v

    @property
    def moves(self) -> bool:
        return any(w[1:] != self.path[0][1:] for w in self.path)


#: |value| limits of a waypoint [t_s, x_mm, y_mm, tip_height_mm, yaw_deg]: an hour, a robot's reach
#: (2 m), ten turns of yaw. Beyond them a path is a typo, and the step and memory counts would explode.
PATH_LIMITS = (3600.0, 2000.0, 2000.0, 2000.0, 3600.0)
#: mm, the largest object size (radius, half-length) and distance from the origin a scene may hold:
#: the sensor is 32 mm across; a 1 m object or one 2 m away is a typo (and 1e308 overflows MuJoCo).
MAX_OBJECT_MM = 1000.0
MAX_DISTANCE_MM = 2000.0


class Table(_S):
    enabled: bool = True
    friction: float = Field(0.5, ge=0, le=10, description="Coulomb coefficient of the table top")


Shape = Literal["sphere", "ellipsoid", "box", "cylinder", "capsule", "mesh"]
_SIZE_COUNT = {"sphere": 1, "ellipsoid": 3, "box": 3, "cylinder": 2, "capsule": 2, "mesh": 1}


def _volume(shape: str, s: list[float]) -> float:
    """Volume of a primitive, mm^3 (sizes as in SceneObject.size)."""
    import math
    if shape == "sphere":
        return 4 / 3 * math.pi * s[0] ** 3
    if shape == "ellipsoid":
        return 4 / 3 * math.pi * s[0] * s[1] * s[2]
    if shape == "box":
        return 8 * s[0] * s[1] * s[2]
    if shape == "cylinder":
        return 2 * math.pi * s[0] ** 2 * s[1]
    if shape == "capsule":
        return 2 * math.pi * s[0] ** 2 * s[1] + 4 / 3 * math.pi * s[0] ** 3
    return 0.0


def _half_height(shape: str, s: list[float]) -> float:
    if shape == "sphere":
        return s[0]
    if shape in ("ellipsoid", "box"):
        return s[2]
    if shape == "cylinder":
        return s[1]
    if shape == "capsule":
        return s[1] + s[0]
    return 0.0


def _bound(shape: str, s: list[float]) -> float:
    if shape == "sphere":
        return s[0]
    if shape == "ellipsoid":
        return max(s)
    if shape == "box":
        return (s[0] ** 2 + s[1] ** 2 + s[2] ** 2) ** 0.5
    return (s[0] ** 2 + s[1] ** 2) ** 0.5 + (s[0] if shape == "capsule" else 0.0)


class Part(_S):
    """A primitive rigidly attached to an object's core: petals, scales, lumps (irregular shapes)."""
    shape: Literal["sphere", "ellipsoid", "box", "cylinder", "capsule"] = "sphere"
    size: list[float] = Field(description="mm, as the object's size")
    pos: list[float] = Field(default_factory=lambda: [0.0, 0.0, 0.0], description="[x, y, z] mm from the core's centre")

    @model_validator(mode="after")
    def _check(self) -> "Part":
        if len(self.size) != _SIZE_COUNT[self.shape] or any(not 0 < v <= MAX_OBJECT_MM for v in self.size):
            raise ValueError(f"part {self.shape} needs {_SIZE_COUNT[self.shape]} size value(s) in (0, "
                             f"{MAX_OBJECT_MM:g}] mm (got {self.size})")
        if len(self.pos) != 3 or any(not abs(v) <= MAX_OBJECT_MM for v in self.pos):
            raise ValueError(f"part pos is [x, y, z] mm within +-{MAX_OBJECT_MM:g} (got {self.pos})")
        return self


class SceneObject(_S):
    name: str
    shape: Shape = "sphere"
    size: list[float] = Field(description="mm: sphere [r]; ellipsoid/box [a, b, c] half-sizes; "
                                          "cylinder/capsule [r, half-length]; mesh [scale]")
    mass: float = Field(gt=0, le=5000, description="g")
    friction: float | None = Field(None, ge=0, le=10, description=(
        "Coulomb coefficient against the sand-coated whisker tips; default the design's "
        "[mechanics] tip_friction (the bare rods use contact.rod_friction, the table table.friction; "
        "whisker.sim.mj)"))
    pos: list[float] = Field(default_factory=lambda: [0.0, 0.0], description="[x, y] mm on the table")
    yaw: float = Field(0.0, ge=-3600, le=3600, description="deg about the vertical")
    mesh: str = Field("", description="mesh file (STL/OBJ), relative to the scene file")
    fixed: bool = Field(False, description="held in place (a static body) instead of free on the table")
    parts: list[Part] = Field(default_factory=list, description="extra primitives on the core (irregular shapes); "
                                                                "the mass is shared by volume")
    material: str | None = Field(None, description="a name in the scene's materials (compliant contact); "
                                                   "none: rigid")

    @model_validator(mode="after")
    def _check(self) -> "SceneObject":
        n = _SIZE_COUNT[self.shape]
        if len(self.size) != n:
            raise ValueError(f"object {self.name!r}: shape {self.shape} needs {n} size value(s), got {len(self.size)}")
        if any(not 0 < s <= MAX_OBJECT_MM for s in self.size):
            raise ValueError(f"object {self.name!r}: sizes must be in (0, {MAX_OBJECT_MM:g}] mm (got {self.size})")
        if len(self.pos) != 2 or any(not abs(v) <= MAX_DISTANCE_MM for v in self.pos):
            raise ValueError(f"object {self.name!r}: pos is [x, y] in mm within +-{MAX_DISTANCE_MM:g} (got {self.pos})")
        if self.shape == "mesh" and not self.mesh:
            raise ValueError(f"object {self.name!r}: shape mesh needs mesh = 'file.stl'")
        return self

    @property
    def half_height(self) -> float:
        """Height of the core's centre above the table when resting upright, mm (its lowest point,
        core or part, on the table)."""
        if self.shape == "mesh":
            return 0.0
        low = _half_height(self.shape, self.size)
        for p in self.parts:
            low = max(low, _half_height(p.shape, p.size) - p.pos[2])
        return low

    @property
    def bounding_radius(self) -> float:
        """Radius of a sphere about the core's centre containing the object, mm (mesh: inf)."""
        if self.shape == "mesh":
            return float("inf")
        r = _bound(self.shape, self.size)
        for p in self.parts:
            r = max(r, (p.pos[0] ** 2 + p.pos[1] ** 2 + p.pos[2] ** 2) ** 0.5 + _bound(p.shape, p.size))
        return r

    def geoms(self) -> list[tuple[str, list[float], list[float], float]]:
        """(shape, size mm, pos mm, mass g) of the core and each part, mass shared by volume."""
        items = [(self.shape, list(self.size), [0.0, 0.0, 0.0])] + [(p.shape, list(p.size), list(p.pos)) for p in self.parts]
        vol = [_volume(sh, sz) for sh, sz, _ in items]
        tot = sum(vol) or 1.0
        return [(sh, sz, ps, self.mass * v / tot) for (sh, sz, ps), v in zip(items, vol)]


class ActEvent(_S):
    t: float = Field(ge=0, le=3600, description="s")
    level: float = Field(ge=-1, le=1, description="signed duty, + retracts")
    whiskers: list[int] | None = Field(None, description="whisker indices; default all")


class ActuationSpec(_S):
    voltage: float | None = Field(None, description="no longer used: refused with a pointer to the design")
    schedule: list[ActEvent] = Field(default_factory=list)

    @field_validator("voltage")
    @classmethod
    def _no_voltage(cls, v: float | None) -> None:
        if v is not None:
            raise ValueError("a level is a fraction of the full-scale coil voltage (whisker.drive.guard."
                             "full_scale_voltage); set it in the design: [design] set = "
                             f"[\"drive.full_scale_voltage={v:g}\"]")
        return None

    @field_validator("schedule")
    @classmethod
    def _sorted(cls, v: list[ActEvent]) -> list[ActEvent]:
        ts = [e.t for e in v]
        if ts != sorted(ts):
            raise ValueError(f"events must be in time order (got t = {ts})")
        return v


class CameraSpec(_S):
    enabled: bool = False
    fps: float = Field(30.0, gt=0, le=1000, description="frames per second")
    noise_sigma: float = Field(2.0, ge=0, le=100, description="grey levels of Gaussian noise")
    blur_px: float = Field(0.8, ge=0, le=20, description="px, Gaussian blur sigma")
    method: str = Field("roi", description="tracking method (whisker.vision.tracking); default roi, the tracker's own "
                                           "default: the paper's pipeline (method 'paper') loses markers on the "
                                           "design's small dots (docs/tracking.md)")
    geometry: Literal["paper", "exact"] = Field("paper", description="pixels -> tip model (whisker.vision.geometry)")
    calibration: str = Field("", description="lens calibration .npz (mtx, dist), relative to the scene: the "
                                             "frames get its distortion and the tracker undistorts; empty: pinhole")


class Outputs(_S):
    record_hz: float = Field(100.0, gt=0, le=100000, description="Hz, how often the state is recorded "
                                                                 "(the camera records at least at its fps)")
    tracks: bool = True
    frames: bool = False
    video: bool = False
    plots: bool = True
    summary: bool = True


class Fidelity(_S):
    magnetics: str = Field("table", description="whisker.coil.magnetics model name")
    magnetics_lookup: int = Field(256, ge=0, le=100000,
                                  description="sample the magnetics model at this many gaps once per run and "
                                              "interpolate (0: call the model every step)")
    heating_interval: float = Field(0.05, gt=0, le=60, description="s between coil-temperature updates "
                                                           "(the coil's thermal time constant is seconds)")
    heating: Literal["auto", "on", "off"] = "auto"
    heating_threshold_K: float = Field(0.5, gt=0, le=1000, description="K of predicted coil rise that turns heating on")
    contact: Literal["auto", "on"] = Field("auto", description="'on' builds MuJoCo even without objects")
    compliance: Literal["auto", "off"] = Field("auto", description=(
        "'auto': compliant (Hertz) contact for the materials the objects and tips name, where the time "
        "step resolves it; 'off': every contact rigid (the model before materials)"))
    solver: Literal["auto", "static", "dynamic"] = "auto"
    integrator: Literal["implicit", "euler"] = "implicit"


class ContactSpec(_S):
    """MuJoCo contact settings (the contact effect); defaults chosen in benchmarks/results/sim.md."""
    rod_friction: float = Field(0.3, ge=0, le=10, description="Coulomb coefficient of the bare carbon rod "
                                                              "(estimate; against the tips an object uses its own friction)")
    tip_coating: float = Field(5.0, gt=0, le=100, description="mm of sand coating at the tip")
    tip_radius_factor: float = Field(1.2, ge=1, le=5, description="coated tip radius / rod radius")
    condim: Literal[1, 3, 4, 6] = Field(4, description="MuJoCo contact dimensionality (4: + torsional friction)")
    patch_radius: float = Field(0.6, ge=0, le=20, description=(
        "mm, radius a of the contact patch for torsional friction: MuJoCo's torsional coefficient is "
        "(2/3) mu a (uniform pressure on a disc); default the coated tip's radius (0.5 mm rod x 1.2), "
        "MuJoCo's own default (5 mm in SI units) would be a patch 8x wider than the tip"))
    cone: Literal["pyramidal", "elliptic"] = "elliptic"
    impratio: float = Field(3.0, ge=1, le=100, description=(
        "MuJoCo friction-to-normal impedance ratio: larger = harder friction (less creep of a held object) "
        "and more solver iterations; 3 is as close to the fine reference as 10 at about half the cost "
        "on compound objects (benchmarks/results/sim.md)"))
    integrator: Literal["Euler", "implicitfast", "implicit", "RK4"] = "implicitfast"
    solref_timeconst: float = Field(0.004, gt=0, le=1, description="s, contact stiffness time constant")
    chunk: int = Field(5, ge=1, le=1000, description="MuJoCo steps between Python updates (path velocity, "
                                                     "coil torque linearisation, heating)")
    tip_material: str | None = Field(None, description="material of the tips' sand cap (compliant contact); none: rigid tips")
    load_range_mN: tuple[float, float] = Field((1.0, 20.0), description=(
        "mN, the normal loads over which a compliant contact follows Hertz (a whisker presses 1-20 mN)"))
    nominal_load_mN: float = Field(2.0, gt=0, le=1000, description=(
        "mN, the load at which a compliant contact's patch radius (torsional friction) is taken: a "
        "closing whisker presses ~1-2 mN (docs/sim.md, Scene 2)"))

    @model_validator(mode="after")
    def _loads(self) -> "ContactSpec":
        lo, hi = self.load_range_mN
        if not 0 < lo < hi <= 1e4:
            raise ValueError(f"contact.load_range_mN must be 0 < low < high <= 1e4 mN (got {list(self.load_range_mN)})")
        return self


class Experiment(_S):
    """Repeat the scene with variations (the paper's experiments); see whisker.sim.experiments.repeat."""
    kind: Literal["none", "angle_vs_voltage", "grasp", "displacement", "classification"] = "none"
    voltages: list[Annotated[float, Field(ge=-100, le=100)]] = Field(default_factory=list, description="V, angle_vs_voltage")
    configurations: list[list[int]] = Field(default_factory=list,
                                            description="grasp: whisker index sets, e.g. [[0..7],[0,2,4,6],[0,4]]")
    attempts: int = Field(20, ge=1, le=10000)
    placement_noise: float = Field(2.0, ge=0, le=50, description="mm, std of the object's (x, y) placement")
    yaw_noise: float = Field(180.0, ge=0, le=360, description="deg, uniform half-range of object yaw")
    lift: float = Field(30.0, ge=0, le=500, description="mm the sensor rises after closing")
    hold_height: float = Field(5.0, ge=0, le=1000, description="mm above the table counted as held at the end")
    objects: list[str] = Field(default_factory=list, description="object names to use (default all)")
    trials: int = Field(5, ge=1, le=1000)
    distances: list[Annotated[float, Field(ge=0, le=MAX_DISTANCE_MM)]] = Field(default_factory=lambda: [30.0, 10.0],
                                   description="mm, classification: object centre to the nearest resting "
                                               "whisker tip (the front of the ring)")
    directions: int = Field(4, ge=1, le=16, description="classification: approach directions")
    rotations: list[Annotated[float, Field(ge=-3600, le=3600)]] = Field(default_factory=lambda: [0.0, 60.0, 120.0, 180.0, 240.0, 300.0],
                                   description="deg, classification: sensor rotations")
    tip_height: float = Field(3.0, ge=0, le=1000, description="mm, tips above the table (classification/grasp)")


class Scene(_S):
    scene: SceneInfo = SceneInfo()
    design: DesignRef = DesignRef()
    sensor: Sensor = Sensor()
    table: Table = Table()
    objects: list[SceneObject] = Field(default_factory=list)
    actuation: ActuationSpec = ActuationSpec()
    camera: CameraSpec = CameraSpec()
    outputs: Outputs = Outputs()
    fidelity: Fidelity = Fidelity()
    contact: ContactSpec = ContactSpec()
    experiment: Experiment = Experiment()
    airflow: AirflowSpec = AirflowSpec()
    materials: dict[str, Material] = Field(default_factory=dict, description="contact materials by name (materials_from)")
    base_dir: str = Field(".", description="folder relative paths resolve against (set by load_scene)")

    @model_validator(mode="after")
    def _names(self) -> "Scene":
        names = [o.name for o in self.objects]
        if len(set(names)) != len(names):
            raise ValueError(f"object names must be unique (got {names})")
        for n in self.experiment.objects:
            if n not in names:
                raise ValueError(f"experiment.objects names {n!r}, which is not an object of the scene")
        known = ", ".join(self.materials) or "none; add materials_from = \"materials.toml\""
        for o in self.objects:
            if o.material is not None and o.material not in self.materials:
                raise ValueError(f"object {o.name!r}: material {o.material!r} is not in the scene's materials ({known})")
        tm = self.contact.tip_material
        if tm is not None and tm not in self.materials:
            raise ValueError(f"contact.tip_material {tm!r} is not in the scene's materials ({known})")
        return self

    # --- derived -------------------------------------------------------------------------------
    @property
    def acts(self) -> bool:
        return any(e.level != 0 for e in self.actuation.schedule) or self.experiment.kind in (
            "angle_vs_voltage", "grasp", "displacement")

    @property
    def actuation_changes(self) -> bool:
        """True when a level changes after t = 0 (so the whiskers move)."""
        return any(e.t > 0 for e in self.actuation.schedule)

    def with_(self, **changes: Any) -> "Scene":
        """A copy with top-level sections replaced (validated again)."""
        data = self.model_dump()
        data.update({k: (v.model_dump() if isinstance(v, BaseModel) else v) for k, v in changes.items()})
        return scene_from_dict(data)


def scene_from_dict(data: dict[str, Any]) -> Scene:
    try:
        return Scene.model_validate(data)
    except ValidationError as err:
        raise SceneError(one_line_errors(err)) from None


def _shared_file(path: Path, data: dict, key: str, section: str, kind: type, what: str):
    """The `section` of the TOML file a scene's top-level `key` names (relative to the scene), or None."""
    src = data.pop(key, None)
    if src is None:
        return None
    if not isinstance(src, str) or not src:
        raise SceneError(f"{key}: expected a TOML file name (got {src!r})")
    f = path.resolve().parent / src
    if not f.is_file():
        raise SceneError(f"{key}: no such file {f}")
    shared = read_toml(f, f"{section} file", SceneError).get(section, kind())
    if not isinstance(shared, kind) or not shared:
        raise SceneError(f"{key}: {f.name} has no {what}")
    return shared


def load_scene(path: str | Path) -> Scene:
    """Read and validate a scene TOML file. Raises :class:`SceneError` (one line) when it is bad.

    A top-level ``objects_from = "FILE.toml"`` (relative to the scene) reads that file's ``[[objects]]``
    ahead of the scene's own, so several scenes share one definition of the paper's objects; a top-level
    ``materials_from = "FILE.toml"`` reads that file's ``[materials.NAME]`` (whisker.sim.materials) under
    the scene's own.
    """
    path = Path(path)
    data = read_toml(path, "scene", SceneError)
    data.setdefault("base_dir", str(path.resolve().parent))
    shared = _shared_file(path, data, "objects_from", "objects", list, "[[objects]]")
    if shared is not None:
        data["objects"] = [*shared, *data.get("objects", [])]
    shared = _shared_file(path, data, "materials_from", "materials", dict, "[materials.NAME] tables")
    if shared is not None:
        data["materials"] = {**shared, **data.get("materials", {})}
    return scene_from_dict(data)


def scene_with_overrides(scene: Scene, overrides) -> Scene:
    """A copy of `scene` with ``section.key=value`` or ``objects.NAME.key=value`` overrides (value in TOML
    syntax), validated again."""
    data = scene.model_dump()
    for item in overrides:
        key, sep, text = str(item).partition("=")
        parts = key.strip().split(".")
        if sep and len(parts) == 3 and parts[0] == "objects" and all(parts):
            _, name, k = parts                       # objects.<name>.<key>: one object, by name
            hit = [o for o in data["objects"] if o["name"] == name]
            if not hit:
                raise SceneError(f"scene override {item!r}: no object named {name!r} (objects: "
                                 f"{', '.join(o['name'] for o in data['objects']) or 'none'})")
            hit[0][k] = parse_value(text.strip())
            continue
        if sep and len(parts) == 3 and parts[0] == "materials" and all(parts):
            _, name, k = parts                       # materials.<name>.<key>: one material, by name
            if name not in data["materials"]:
                raise SceneError(f"scene override {item!r}: no material named {name!r} (materials: "
                                 f"{', '.join(data['materials']) or 'none'})")
            data["materials"][name][k] = parse_value(text.strip())
            continue
        if not sep or len(parts) != 2 or not all(parts):
            raise SceneError(f"scene override {item!r}: expected section.key=value, objects.NAME.key=value or materials.NAME.key=value")
        sec, k = parts
        if not isinstance(data.get(sec), dict):
            raise SceneError(f"scene override {item!r}: no section {sec!r} (one of "
                             f"{', '.join(n for n, v in data.items() if isinstance(v, dict))})")
        data[sec][k] = parse_value(text.strip())  # a TOML value; a bare word is a string
    return scene_from_dict(data)


def scene_design(scene: Scene, extra_overrides: tuple[str, ...] = (), design_file=None):
    """The validated Design the scene names (file relative to the scene, then overrides);
    `design_file` (e.g. `whisker sim --design`) replaces the scene's design file."""
    from whisker.design import DesignError, load_design

    f = scene.design.file
    path = Path(design_file) if design_file else ((Path(scene.base_dir) / f) if f else None)
    try:
        return load_design(path, [*scene.design.set, *extra_overrides])
    except DesignError as err:
        raise SceneError(f"design: {err}") from None
