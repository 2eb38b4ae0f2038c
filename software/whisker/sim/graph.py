"""The effect graph's types: one :class:`Effect` (built or skipped, with its reason) and the
:class:`Plan` of a scene (whisker.sim.effects.plan decides them). Plain data; imports nothing of the simulator."""

from __future__ import annotations

from dataclasses import dataclass, field


@dataclass(frozen=True)
class Effect:
    name: str
    built: bool
    reason: str
    needs: tuple[str, ...] = ()
    detail: dict = field(default_factory=dict)


@dataclass(frozen=True)
class Plan:
    effects: tuple[Effect, ...]
    solver: str                   # "static", "free" (own integrator) or "mujoco"

    def built(self, name: str) -> bool:
        return any(e.name == name and e.built for e in self.effects)

    def effect(self, name: str) -> Effect:
        return next(e for e in self.effects if e.name == name)

    @property
    def names(self) -> list[str]:
        return [e.name for e in self.effects if e.built]

    def explain(self) -> str:
        lines = []
        for e in self.effects:
            mark = "built  " if e.built else "skipped"
            lines.append(f"{mark} {e.name:<11} {e.reason}")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"solver": self.solver,
                "effects": [{"name": e.name, "built": e.built, "reason": e.reason} for e in self.effects]}
