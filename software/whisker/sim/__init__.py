"""Scene simulator: only the effects a scene calls for (see docs/sim.md).

    load_scene(path) -> Scene            the TOML scene model (whisker.sim.scene)
    plan(scene, design) -> Plan          the effect graph, each effect with its reason (effects)
    simulate(scene) -> Result            static solve, own integrator or MuJoCo (simulate, mj)
    run_experiment(scene) -> dict        the paper's experiments (experiments)
    actuation_backend(design)            set_levels/off backend for `whisker actuate --backend sim`
"""

from whisker.drive.simulated import SimBackend, actuation_backend
from whisker.sim.effects.plan import Plan, plan
from whisker.sim.scene import Scene, SceneError, load_scene, scene_design, scene_from_dict
from whisker.sim.simulate import Result, SimulationError, simulate

__all__ = ["SimBackend", "actuation_backend", "Plan", "plan", "Scene", "SceneError", "load_scene",
           "scene_design", "scene_from_dict", "Result", "SimulationError", "simulate"]
