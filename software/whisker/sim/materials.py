"""Contact materials: Young's modulus, Poisson ratio, loss factor (and a friction for the tips' cap),
each with the published range it was taken from and a source (scenes/materials.toml).

A scene loads them with ``materials_from = "materials.toml"`` (or its own ``[materials.NAME]``);
objects name theirs with ``material``, the tips with ``[contact] tip_material``. Values outside their
stated range are refused, so a sensitivity sweep stays within what the sources support.
"""

from __future__ import annotations

from pydantic import BaseModel, ConfigDict, Field, model_validator


class Material(BaseModel):
    model_config = ConfigDict(extra="forbid")

    youngs_modulus_Pa: float = Field(gt=0, le=1e12, description="Pa (or the equivalent half-space modulus, see the note)")
    youngs_modulus_range_Pa: tuple[float, float] = Field(description="Pa, the published range")
    poisson: float = Field(ge=0, le=0.5)
    poisson_range: tuple[float, float]
    loss_factor: float = Field(ge=0, le=4, description="eta = tan(delta); contact damping ratio eta / 2")
    loss_factor_range: tuple[float, float]
    friction: float | None = Field(None, ge=0, le=10, description="Coulomb coefficient (tip caps: the default "
                                                                  "for objects without their own pair value)")
    friction_range: tuple[float, float] | None = None
    source: str = Field(min_length=3, description="where the values and ranges come from")

    @model_validator(mode="after")
    def _in_range(self) -> "Material":
        pairs = [("youngs_modulus_Pa", self.youngs_modulus_Pa, self.youngs_modulus_range_Pa),
                 ("poisson", self.poisson, self.poisson_range),
                 ("loss_factor", self.loss_factor, self.loss_factor_range)]
        if self.friction is not None:
            if self.friction_range is None:
                raise ValueError("friction needs friction_range (the published range)")
            pairs.append(("friction", self.friction, self.friction_range))
        for name, v, (lo, hi) in pairs:
            if not lo <= hi:
                raise ValueError(f"{name}: range [{lo:g}, {hi:g}] is empty")
            if not lo <= v <= hi:
                raise ValueError(f"{name} = {v:g} is outside its published range [{lo:g}, {hi:g}]")
        return self


#: the parameters a sensitivity sweep moves, with the Material field holding each range
SWEPT = {"youngs_modulus_Pa": "youngs_modulus_range_Pa", "loss_factor": "loss_factor_range",
         "poisson": "poisson_range", "friction": "friction_range"}
