"""A scene's drive and path against time: coil levels and sensor poses (piecewise constant levels,
linear moves between waypoints). Used by the plan (reach, heating) and by the stepping loops."""

from __future__ import annotations

import numpy as np

from whisker.sim.scene import Scene, SceneError


def levels_at(scene: Scene, n: int, t: float) -> np.ndarray:
    """Signed duty of each of `n` whiskers at time t from the schedule (piecewise constant)."""
    lv = np.zeros(n)
    for ev in scene.actuation.schedule:
        if ev.t > t:
            break
        idx = range(n) if ev.whiskers is None else ev.whiskers
        for i in idx:
            if not 0 <= i < n:
                raise SceneError(f"actuation.schedule: whisker {i} does not exist (the design has {n})")
            lv[i] = ev.level
    return lv


def levels_table(scene: Scene, n: int, times: np.ndarray) -> np.ndarray:
    """Levels (T, n) at each of `times` (vectorised :func:`levels_at`)."""
    times = np.asarray(times, dtype=float)
    out = np.zeros((len(times), n))
    for ev in scene.actuation.schedule:
        idx = list(range(n)) if ev.whiskers is None else ev.whiskers
        for i in idx:
            if not 0 <= i < n:
                raise SceneError(f"actuation.schedule: whisker {i} does not exist (the design has {n})")
        out[np.ix_(times >= ev.t, idx)] = ev.level
    return out


def poses_table(scene: Scene, times: np.ndarray) -> np.ndarray:
    """Poses (T, 4) at each of `times` (vectorised :func:`pose_at`)."""
    p = np.asarray(scene.sensor.path, dtype=float)
    times = np.asarray(times, dtype=float)
    if len(p) == 1:
        return np.repeat(p[:1, 1:], len(times), axis=0)
    return np.stack([np.interp(times, p[:, 0], p[:, k]) for k in range(1, 5)], axis=1)


def pose_at(scene: Scene, t: float) -> np.ndarray:
    """Sensor pose [x_mm, y_mm, tip_height_mm, yaw_deg] at time t (linear between waypoints)."""
    p = np.asarray(scene.sensor.path, dtype=float)
    if len(p) == 1:
        return p[0, 1:].copy()
    return np.array([np.interp(t, p[:, 0], p[:, k]) for k in range(1, 5)])


def path_samples(scene: Scene, duration: float) -> np.ndarray:
    p = np.asarray(scene.sensor.path, dtype=float)
    t_end = max(duration, p[-1, 0])
    ts = np.unique(np.concatenate([p[:, 0], np.linspace(0, t_end, 200)]))
    return np.array([pose_at(scene, t) for t in ts])
