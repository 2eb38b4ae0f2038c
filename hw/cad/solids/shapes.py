"""Primitive solids shared by the part models (all dimensions in mm, angles in degrees)."""

from __future__ import annotations

import math
from typing import Iterable

import cadquery as cq

Z = cq.Vector(0, 0, 1)
ORIGIN = cq.Vector(0, 0, 0)


def polygon_points(sides: int, inscribed_radius: float) -> list[tuple[float, float]]:
    """Vertices of a regular polygon with a flat facing +x (so whisker 0 faces a flat)."""
    rc = inscribed_radius / math.cos(math.pi / sides)
    return [(rc * math.cos(math.pi * (2 * i + 1) / sides), rc * math.sin(math.pi * (2 * i + 1) / sides))
            for i in range(sides)]


def prism(points: list[tuple[float, float]], z0: float, z1: float) -> cq.Solid:
    """A vertical prism over a closed 2D outline from z0 to z1."""
    return cq.Workplane("XY", origin=(0, 0, z0)).polyline(points).close().extrude(z1 - z0).val()


def polygon_prism(sides: int, inscribed_radius: float, z0: float, z1: float) -> cq.Solid:
    return prism(polygon_points(sides, inscribed_radius), z0, z1)


def cylinder(radius: float, z0: float, z1: float, x: float = 0.0, y: float = 0.0) -> cq.Solid:
    """Vertical cylinder from z0 to z1 centred on (x, y)."""
    return cq.Solid.makeCylinder(radius, z1 - z0, cq.Vector(x, y, z0), Z)


def cone(r0: float, r1: float, z0: float, z1: float) -> cq.Solid:
    """Vertical truncated cone, radius r0 at z0 and r1 at z1."""
    return cq.Solid.makeCone(r0, r1, z1 - z0, cq.Vector(0, 0, z0), Z)


def revolved(profile_rz: list[tuple[float, float]]) -> cq.Solid:
    """Solid of revolution about the z axis from a closed (r, z) outline (r >= 0)."""
    return cq.Workplane("XZ").polyline(profile_rz).close().revolve(360, (0, 0, 0), (0, 1, 0)).val()


def radial_cylinder(r_from: float, r_to: float, diameter: float, z: float, angle_deg: float) -> cq.Solid:
    """Cylinder whose axis runs radially outwards at height z from r_from to r_to."""
    c = cq.Solid.makeCylinder(diameter / 2.0, r_to - r_from, cq.Vector(r_from, 0, z), cq.Vector(1, 0, 0))
    return c.rotate(ORIGIN, Z, angle_deg)


def at_polar(shape: cq.Shape, radius: float, angle_deg: float) -> cq.Shape:
    """Move a shape built at the origin to (radius, 0) and turn it by angle_deg about z."""
    return shape.translate(cq.Vector(radius, 0, 0)).rotate(ORIGIN, Z, angle_deg)


def polar_xy(radius: float, angle_deg: float) -> tuple[float, float]:
    a = math.radians(angle_deg)
    return radius * math.cos(a), radius * math.sin(a)


def compound(shapes: Iterable[cq.Shape]) -> cq.Compound:
    return cq.Compound.makeCompound(list(shapes))


def cut_all(body: cq.Shape, tools: Iterable[cq.Shape]) -> cq.Shape:
    """Cut every tool from body in one boolean (much faster than one cut per tool)."""
    tools = list(tools)
    return body.cut(*tools).clean() if tools else body
