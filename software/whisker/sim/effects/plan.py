"""The effect graph: which physical effects a scene needs, and why (the simulator's Principle 3).

:func:`plan` reads a scene (and its design) and decides, effect by effect, whether to build it,
with a one-line reason either way. The simulator builds exactly the effects marked ``built``;
``whisker sim SCENE --explain`` prints the list. Effects and their dependencies:

    kinematics   always: the whiskers are rigid rods on the membrane spring (whisker.coil.kinematics)
    gravity      always: the rods' weight about the pivot (cheap, a few % of the membrane stiffness)
    motion       the sensor follows a path with more than one pose
    magnetics    some whisker is driven at a non-zero level            (needs kinematics)
    heating      magnetics, and the drive would warm a coil by more than the threshold (needs magnetics)
    contact      an object within reach of the tips along the path, or the tips reach the table,
                 or fidelity.contact = "on" (MuJoCo: capsule whiskers, bodies, friction, gravity)
    compliance   contact, and an object or the tips name a material soft enough for the time step:
                 Hertz contact mapped onto MuJoCo's solref/solimp (whisker.sim.effects.compliant; one module
                 per contact model, listed in CONTACT_MODELS)  (needs contact)
    airflow      the scene has a flow (whisker.sim.effects.airflow)
    camera       the camera is on and frames, video or tracks are wanted (whisker.vision.render)
    tracking     the camera is built and tracks are wanted (whisker.vision.tracking + whisker.vision.geometry)
    solver       static equilibrium when nothing moves, else time stepping (MuJoCo when contact)
"""

from __future__ import annotations

import math

import numpy as np

from whisker.sim.graph import Effect, Plan
from whisker.sim.scene import Scene, SceneError
from whisker.sim.drive import levels_at, path_samples

from whisker.sim.effects import compliant
from whisker.mechanics.membrane import design_stiffness_Nmm_per_rad

ORDER = ("kinematics", "gravity", "motion", "magnetics", "heating", "contact", "compliance", "airflow", "camera",
         "tracking", "solver")
#: contact models beyond the rigid one, in the order they are applied (each: NAME, effect(), apply();
#: see whisker.sim.effects.compliant). Adding a contact model = its module + one entry here.
CONTACT_MODELS = (compliant,)


def reach(design, body) -> tuple[float, float]:
    """(largest horizontal tip radius, lowest tip drop) any whisker reaches within its stops, mm."""
    s = math.sin(body.stop_rad)
    return design.whiskers.ring_radius + design.l_u * s, 0.0


def objects_in_reach(scene: Scene, design, margin_mm: float = 1.0) -> list[str]:
    """Names of the objects a whisker can touch somewhere along the path.

    A conservative bound: the object's bounding sphere (resting on the table) against the cylinder
    the tips sweep (radius ring + l_u sin(stop)) from the tips' height down... up to the rods' whole
    length above the tips (a rod can touch with its side).
    """
    if not scene.objects:
        return []
    duration = scene.scene.duration
    poses = path_samples(scene, duration)
    r_reach = design.whiskers.ring_radius + design.l_u * math.sin(math.radians(35)) + margin_mm
    out = []
    for o in scene.objects:
        rb = o.bounding_radius
        if not math.isfinite(rb):
            out.append(o.name)
            continue
        top = o.half_height + rb
        horiz = np.hypot(poses[:, 0] - o.pos[0], poses[:, 1] - o.pos[1])
        near = horiz <= r_reach + rb
        low = poses[:, 2] <= top + margin_mm
        if scene.sensor.facing == "up":
            low = np.ones_like(low)
        if np.any(near & low):
            out.append(o.name)
    return out


def predicted_rise_K(scene: Scene, design) -> float:
    """Largest coil temperature rise the schedule would cause (whisker.coil.thermal, heated by the PWM's RMS
    current), K.

    The schedule is piecewise constant, so each coil is stepped once per segment (CoilThermal.step
    sub-steps internally).
    """
    from whisker.sim.contract import coil_thermal, current_A, pwm_rms_current_A

    duration = scene.scene.duration
    if duration <= 0:
        return 0.0
    n = design.whiskers.count
    from whisker.sim.contract import full_scale_voltage
    volts = full_scale_voltage(design)
    th = coil_thermal(design)
    T0 = float(th.ambient_C)
    cuts = sorted({0.0, duration, *[e.t for e in scene.actuation.schedule if e.t < duration]})
    T = np.full(n, T0)
    peak = 0.0
    for a, b in zip(cuts, cuts[1:]):
        lv = levels_at(scene, n, a)
        if not np.any(lv):
            T = np.array([th.step(float(T[i]), 0.0, b - a) for i in range(n)])
            continue
        I = pwm_rms_current_A(np.atleast_1d(current_A(design, np.abs(lv) * volts, T)), lv)
        T = np.array([th.step(float(T[i]), float(I[i]), b - a) for i in range(n)])
        peak = max(peak, float(np.max(T - T0)))
    return peak


def plan(scene: Scene, design) -> Plan:
    """Decide the effects of `scene` and the solver, each with its reason."""
    from whisker.sim.contract import MissingModule
    from whisker.coil.kinematics import gravity_torque, whisker_body

    fid = scene.fidelity
    ex = scene.experiment.kind
    mech = design.mechanics
    n = design.whiskers.count
    effects: list[Effect] = []
    try:
        body = whisker_body(design)
    except MissingModule as err:  # explain still works; running will fail with this message
        body, missing = None, str(err)
    if body is not None:
        effects.append(Effect("kinematics", True,
                              f"{n} rigid rods about the pivot: k = {design_stiffness_Nmm_per_rad(design):.4g} N*mm/rad, "
                              f"zeta = {mech.damping_ratio:g}, J = {body.inertia_kgm2 * 1e9:.3g} g*mm^2, "
                              f"f_n = {body.omega_n / (2 * math.pi):.3g} Hz"))
        kg = abs(float(gravity_torque(body, 1.0, scene.sensor.facing))) / math.sin(1.0)
        effects.append(Effect("gravity", True,
                              f"rod + coil weight about the pivot: {kg * 1e3:.3g} N*mm/rad = "
                              f"{100 * kg / body.stiffness:.2g} % of the membrane stiffness "
                              f"({'restoring, hanging' if scene.sensor.facing == 'down' else 'destabilising, standing'})"))
    else:
        effects.append(Effect("kinematics", True, f"{n} rigid rods about the pivot (inertia unknown: {missing})"))
        effects.append(Effect("gravity", True, "rod + coil weight about the pivot"))
    moves = scene.sensor.moves or ex in ("grasp", "displacement", "classification")
    effects.append(Effect("motion", moves,
                          "the sensor follows a path (prescribed, like the UR16e)" if moves
                          else "the sensor stays put (one pose)"))
    acts = scene.acts
    drive = ""
    if acts:
        from whisker.sim.contract import full_scale_voltage
        try:
            v_fs = full_scale_voltage(design)
        except MissingModule as err:
            drive = f"level x full-scale voltage ({err})"
        else:
            if ex in ("grasp", "displacement"):
                drive = (f"at {design.actuation.voltage:g} V = level {design.actuation.voltage / v_fs:.3g} of "
                         f"the {v_fs:.3g} V full scale")
            elif ex == "angle_vs_voltage":
                drive = "at the experiment's voltages"
            else:
                top = max([abs(e.level) for e in scene.actuation.schedule] or [1.0])
                drive = f"up to level {top:g} x {v_fs:.3g} V full scale"
    effects.append(Effect("magnetics", acts,
                          f"coils driven ({drive}): force from whisker.coil.magnetics "
                          f"model {fid.magnetics!r}, torque about the pivot" if acts
                          else "no actuation in the scene (every level is 0)", needs=("kinematics",)))
    # heating
    attempts = ex in ("grasp", "displacement") and bool(scene.objects)
    if not acts:
        heat, why = False, "no coil is driven"
    elif fid.heating == "on":
        heat, why = True, "fidelity.heating = 'on'"
    elif fid.heating == "off":
        heat, why = False, "fidelity.heating = 'off'"
    elif not attempts and (ex == "angle_vs_voltage" or scene.scene.duration <= 0):
        heat, why = False, "static solve: no drive time for a coil to warm (steady angle at ambient)"
    else:
        # an experiment's coils warm during one of its attempts; a plain scene's during its schedule
        try:
            if attempts:
                from whisker.sim.protocol import grasp_level, grasp_scene
                rep = grasp_scene(scene, scene.objects[0], list(range(n)), release=ex == "displacement",
                                  level=grasp_level(design))
                what = f"one {ex} attempt ({rep.scene.duration:.2g} s)"
            else:
                rep, what = scene, "the schedule"
            rise = predicted_rise_K(rep, design)
        except MissingModule as err:
            heat, why = False, f"cannot predict the coil's warming, run at ambient ({err})"
        else:
            heat = rise > fid.heating_threshold_K
            why = f"{what} warms a coil by {rise:.2g} K ({'>' if heat else '<='} {fid.heating_threshold_K:g} K)"
            if not attempts:
                why += f": resistance and current change {'enough to matter' if heat else 'too little to matter'}"
    effects.append(Effect("heating", heat, why, needs=("magnetics",)))
    # contact
    reachable = objects_in_reach(scene, design)
    if fid.contact == "on":
        contact, why = True, "fidelity.contact = 'on' (full model)"
    elif ex in ("grasp", "displacement", "classification") and scene.objects:
        contact, why = True, (f"the {ex} experiment brings the tips to the objects: MuJoCo capsule whiskers "
                              f"(tips grip with each object's friction, bare rods {scene.contact.rod_friction:g}), bodies, gravity")
    elif reachable:
        contact, why = True, (f"object(s) {', '.join(reachable)} within reach of the tips: MuJoCo capsule "
                              f"whiskers (tips grip with each object's friction, bare rods {scene.contact.rod_friction:g}), bodies, gravity")
    elif scene.objects:
        contact, why = False, (f"object(s) {', '.join(o.name for o in scene.objects)} out of reach of the "
                               f"tips along the path")
    else:
        contact, why = False, "no objects in the scene"
    tips_low = scene.table.enabled and scene.sensor.facing == "down" and min(
        w[3] for w in scene.sensor.path) <= 0.0
    if not contact and tips_low:
        contact, why = True, "the tips reach the table top (tip height <= 0 mm on the path)"
    effects.append(Effect("contact", contact, why, needs=("kinematics", "gravity")))
    for model in CONTACT_MODELS:
        effects.append(model.effect(scene, design, contact, body))
    from whisker.sim.effects.airflow import effect as airflow_effect
    effects.append(airflow_effect(scene.airflow, design, body.stiffness if body is not None else None))
    if scene.airflow.on and contact:
        raise SceneError("airflow with contact is not modelled in MuJoCo yet: remove the objects or the [airflow] section")
    cam_wanted = scene.outputs.frames or scene.outputs.video or scene.outputs.tracks
    cam = scene.camera.enabled and cam_wanted
    effects.append(Effect("camera", cam,
                          f"frames at {scene.camera.fps:g} fps, noise {scene.camera.noise_sigma:g}, blur "
                          f"{scene.camera.blur_px:g} px (whisker.vision.render)" if cam else
                          ("camera off in the scene" if not scene.camera.enabled else
                           "no frames, video or tracks asked for"), needs=("kinematics",)))
    trk = cam and scene.outputs.tracks
    effects.append(Effect("tracking", trk,
                          f"tracks asked for: whisker.vision.tracking method {scene.camera.method!r} + geometry"
                          if trk else "no camera tracks asked for", needs=("camera",)))
    # solver
    static_ok = (not contact and not moves and not scene.actuation_changes
                 and scene.scene.initial_tilt_deg == 0 and not scene.airflow.on)
    if fid.solver == "static" and not static_ok:
        raise SceneError("fidelity.solver = 'static' but the scene moves (contact, path or a changing "
                         "actuation level); use 'auto' or 'dynamic'")
    if fid.solver == "static" or (fid.solver == "auto" and (static_ok or ex == "angle_vs_voltage")):
        solver, why = "static", ("nothing moves (no contact, one pose, constant drive): "
                                 "static equilibrium solve instead of time stepping")
    elif contact:
        solver, why = "mujoco", f"contact: MuJoCo time stepping, dt = {scene.scene.timestep:g} s"
    else:
        solver, why = "free", (f"whiskers move without contact: {fid.integrator} spring-damper "
                               f"integrator, dt = {scene.scene.timestep:g} s")
    effects.append(Effect("solver", True, f"{solver}: {why}"))
    return Plan(effects=tuple(effects), solver=solver)
