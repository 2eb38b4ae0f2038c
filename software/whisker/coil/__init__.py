"""The coil actuator's physics, from the design: the winding report and the whisker's steady tilt
(:mod:`~whisker.coil.tilt`), the coil-magnet force (:mod:`~whisker.coil.magnetics`), heat
(:mod:`~whisker.coil.thermal`), the H-bridge drive (:mod:`~whisker.coil.driver`), the rigid-whisker
kinematics under the coil's torque (:mod:`~whisker.coil.kinematics`) and the report
(:mod:`~whisker.coil.report`).

``whisker.coil.winding(design)``, ``whisker.coil.deflection_deg(...)`` and the other names of the coil
calculator are re-exported here (the wire model lives at the design layer, :mod:`whisker.design.wire`);
the modules inside import each other directly, never this package.
"""

from whisker.coil.tilt import (Equilibrium, SnapThrough, Winding, current_A, current_density_A_mm2,
                               deflection_deg, equilibrium, fit_stiffness, gap_at_mm, inductance_numeric_H,
                               lever_mm, magnetic_moment_Am2, pull_in, resistance_ohm, resistance_range_vs_fill,
                               torque_per_ampere_Nmm, wheeler_inductance_H, winding)
from whisker.design.wire import (ALPHA20_PER_K, COPPER_DENSITY_G_CM3, COPPER_SPECIFIC_HEAT, ENAMEL_DENSITY_G_CM3,
                                 ENAMEL_SPECIFIC_HEAT, ORTHOCYCLIC_PACKING, RHO20_OHM_MM2_PER_M, CoilError,
                                 enamel_overall_diameter_mm, ohm_per_m, temperature_factor)

__all__ = ["ALPHA20_PER_K", "COPPER_DENSITY_G_CM3", "COPPER_SPECIFIC_HEAT", "CoilError", "ENAMEL_DENSITY_G_CM3",
           "ENAMEL_SPECIFIC_HEAT", "Equilibrium", "ORTHOCYCLIC_PACKING", "RHO20_OHM_MM2_PER_M", "SnapThrough",
           "Winding", "current_A", "current_density_A_mm2", "deflection_deg", "enamel_overall_diameter_mm",
           "equilibrium", "fit_stiffness", "gap_at_mm", "inductance_numeric_H", "lever_mm", "magnetic_moment_Am2",
           "ohm_per_m", "pull_in", "resistance_ohm", "resistance_range_vs_fill", "temperature_factor",
           "torque_per_ampere_Nmm", "wheeler_inductance_H", "winding"]
