"""The optional parts of the install (pyproject.toml's extras) and what each command needs.

The core install runs the sensor; CAD, the simulator, the netlist and the magnetic field model are
extras. A command that imports a missing extra's library ends with one line naming the
``pip install`` that adds it (:func:`missing_extra_message`, used by whisker.cli).
"""

from __future__ import annotations

from importlib import metadata

DIST = "whisker-array"

#: Top-level modules whisker imports from each extra (the extra that brings them when missing).
MODULES = {
    "cad": ("cadquery", "OCP", "trimesh", "manifold3d", "rtree", "networkx"),
    "sim": ("mujoco",),
    "hw": ("skidl", "kinparse", "schematizer"),
    "magnetics": ("magpylib",),
    "pi": ("lgpio", "smbus2"),
    "explore": ("dask", "distributed"),
    "tolerance": ("SALib",),
    "fem": ("skfem", "triangle"),
    # ROS 2 client library and message packages (the wheels of the [ros] extra, or a ROS 2 install)
    "ros": ("rclpy", "rcl_interfaces", "sensor_msgs", "geometry_msgs", "std_msgs", "std_srvs", "diagnostic_msgs",
            "builtin_interfaces"),
}
_EXTRA_OF = {m: extra for extra, mods in MODULES.items() for m in mods}


def install_command(extra: str) -> str:
    return f"pip install '{DIST}[{extra}]'"


def extra_for_module(name: str | None) -> str | None:
    """The extra that provides the (possibly dotted) module ``name``, or None if none does."""
    return _EXTRA_OF.get((name or "").partition(".")[0])


def missing_extra_message(err: ModuleNotFoundError, command: str = "this command") -> str | None:
    """One line for a missing optional library, or None when ``err`` is not about an extra."""
    extra = extra_for_module(err.name)
    if extra is None:
        return None
    return f"{command} needs {err.name.partition('.')[0]} from the [{extra}] extra: {install_command(extra)}"


def extras_status() -> dict[str, list[str]]:
    """{extra: [requirements not satisfied]} for every extra of the installed package that asks for
    something on this machine (empty list: installed; [pi] is left out off ARM boards). Versions are
    checked against the declared bounds."""
    from packaging.requirements import Requirement

    reqs = [Requirement(r) for r in (metadata.requires(DIST) or [])]
    names = sorted({e for e in metadata.metadata(DIST).get_all("Provides-Extra") or []} - {"test"})
    out: dict[str, list[str]] = {}
    # the extras [all] names (whisker-array[cad,sim,...]): [ros] is not one of them
    in_all = {e for r in reqs if r.name == DIST and r.marker is not None and r.marker.evaluate({"extra": "all"})
              for e in r.extras}
    for extra in names:
        missing, applies = [], False
        for r in reqs:
            if r.name == DIST or r.marker is None or not r.marker.evaluate({"extra": extra}):
                continue
            if r.marker.evaluate({"extra": ""}):  # a core requirement, not this extra's
                continue
            applies = True
            try:
                version = metadata.version(r.name)
            except metadata.PackageNotFoundError:
                missing.append(str(r.name))
                continue
            if version not in r.specifier:
                missing.append(f"{r.name} {version} (needs {r.specifier})")
        if applies or extra == "all":
            out[extra] = missing
    if "all" in out:  # all = the extras it names; what it lacks is what they lack
        out["all"] = sorted({m for e, ms in out.items() if e in in_all for m in ms})
    return out
