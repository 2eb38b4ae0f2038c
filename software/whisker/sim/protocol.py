"""The grasp protocol (paper Section III-B) as scenes: its timeline, the drive level, one attempt as
a plain scene, and where an attempt puts the object. Below the plan (whisker.sim.effects.plan predicts a
grasp's coil heating from :func:`grasp_scene`) and the experiments (whisker.sim.experiments.paper runs them).

The sensor starts ``START_HEIGHT`` mm above the object's top, descends until the tips are
``experiment.tip_height`` mm above the table, drives the configuration's coils at the design's
``actuation.voltage`` as a level of the full-scale coil voltage (:func:`grasp_level`), waits for the
whiskers to close, lifts ``experiment.lift`` mm and holds.
"""

from __future__ import annotations

from dataclasses import dataclass

from whisker.sim.meshes import mesh_bounds
from whisker.sim.scene import Scene, SceneError, scene_from_dict

# grasp timeline, s
T_DOWN, T_CLOSE, T_LIFT, T_HOLD, T_RELEASE = 0.3, 0.3, 0.5, 0.4, 0.4
START_HEIGHT = 15.0   # mm of tip clearance above the object's top at the start


def grasp_level(design) -> float:
    """The grasp's level: the design's ``actuation.voltage`` (paper: 3 V) / the full-scale coil voltage
    (``whisker.drive.guard``; refused above the coil rating or beyond full scale)."""
    from whisker.sim.contract import volts_to_level
    try:
        return volts_to_level(design, design.actuation.voltage)
    except ValueError as err:
        raise SceneError(f"grasp: actuation.voltage: {err}") from None


def grasp_scene(scene: Scene, obj, active: list[int], *, dx=0.0, dy=0.0, obj_yaw=0.0, sensor_yaw=0.0,
                release: bool = False, level: float = 1.0) -> Scene:
    """One grasp attempt as a plain scene (path + schedule + the one object)."""
    e = scene.experiment
    h = e.tip_height
    if obj.shape == "mesh":
        b = mesh_bounds(scene, obj)
        height = float(b[1, 2] - b[0, 2]) * obj.size[0]
    else:
        height = obj.half_height + obj.bounding_radius
    top = height + START_HEIGHT
    t1 = T_DOWN
    t2 = t1 + T_CLOSE
    t3 = t2 + T_LIFT
    t4 = t3 + T_HOLD
    path = [[0.0, 0.0, 0.0, top, sensor_yaw], [t1, 0.0, 0.0, h, sensor_yaw], [t2, 0.0, 0.0, h, sensor_yaw],
            [t3, 0.0, 0.0, h + e.lift, sensor_yaw], [t4, 0.0, 0.0, h + e.lift, sensor_yaw]]
    sched = [{"t": t1, "level": float(level), "whiskers": list(active)}]
    duration = t4
    if release:
        sched.append({"t": t4, "level": 0.0})
        duration = t4 + T_RELEASE
        path.append([duration, 0.0, 0.0, h + e.lift, sensor_yaw])
    o = obj.model_dump()
    o["pos"] = [obj.pos[0] + dx, obj.pos[1] + dy]
    o["yaw"] = obj.yaw + obj_yaw
    data = scene.model_dump()
    data["objects"] = [o]
    data["sensor"] = {"facing": "down", "path": path}
    data["actuation"] = {**data["actuation"], "schedule": sched}
    data["scene"] = {**data["scene"], "duration": duration}
    data["experiment"] = {"kind": "none"}
    data["camera"] = {**data["camera"], "enabled": False}
    return scene_from_dict(data)


@dataclass(frozen=True)
class Placement:
    """Where one attempt puts the object: offset (mm) from the sensor axis, object and sensor yaw (deg)."""
    dx: float = 0.0
    dy: float = 0.0
    obj_yaw: float = 0.0
    sensor_yaw: float = 0.0


def draw_placement(scene, design, rng) -> Placement:
    """The object's (x, y) ~ N(0, placement_noise^2) per axis, its yaw uniform in +-yaw_noise, the
    sensor's yaw uniform over one whisker spacing."""
    e = scene.experiment
    dx, dy = rng.normal(0.0, e.placement_noise, 2) if e.placement_noise > 0 else (0.0, 0.0)
    oyaw = rng.uniform(-e.yaw_noise, e.yaw_noise)
    n = design.whiskers.count
    return Placement(float(dx), float(dy), float(oyaw), float(rng.uniform(-180.0 / n, 180.0 / n)))
