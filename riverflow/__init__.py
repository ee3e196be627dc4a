"""riverflow: real-time flowing rivers for 3-D games and simulators.

A re-implementation of Proland's river plugin and of Yu et al., *Scalable Real-Time Animation
of Rivers* (Eurographics 2009): a procedural, divergence-free velocity field computed locally
from the river banks, wave sprites carried by screen-space particles, and a water surface
blended from those sprites.

Public API (SPEC §6)::

    import riverflow as rf
    graph = rf.load_graph(path)            # any Proland hydro-graph variant; raises rf.GraphError
    rf.save_graph(graph, path)             # ASCII basic variant; load(save(g)) == g
    scene = rf.default_scene(seed=0)       # built-in landscape: scene.graph, scene.terrain
    scene = rf.default_scene(seed=0, size_km=200.0)    # a much larger one, streamed
    scene = rf.landscape(graph, terrain=None, seed=0)  # any network, on hills or your terrain
    field = rf.FlowField(graph, slip=1.0, search_radius_factor=5.0)
    status, velocity = field.query(xy)     # (N,) uint8 FlowStatus, (N, 2) float32 [m/s]
    psi = field.potential(xy)              # (N,) float64, NaN outside the water
    world = rf.RiverWorld(scene, size=(W, H), gl=False, seed=0)
    world.camera.look_at(eye_xyz, target_xyz)
    world.step(dt_s)                       # world.particles, world.timings_ms
    world.particles.foam                   # (N,) each live particle's foam in [0, 1]
    world.foam; world.wake(boat_entity)    # the foam's knobs (FoamSettings), a boat's Wake
    builder = rf.read_rivers(path)         # GIS stream lines → RiverNetworkBuilder (riverflow[gis])
    builder = rf.read_water(path)          # water polygons / masks → RiverNetworkBuilder (riverflow[gis])
    rf.bake_flow_map(scene, region_m, cell_m, "flow.png")   # flow-map PNG + flow.json
    spill = world.add_spill(xy_m, mass_kg, duration_s=0.0, name=None, decay_per_s=0.0)
    world.advance_spills(seconds); world.concentration(xy)  # (N,) kg/m³; world.spill(spill)
    rf.bake_concentration(world, region_m, cell_m, "out/spill", times_s)   # GeoTIFF/PNG + CSV
    rf.bake_flow_map(..., preset="unity")  # also unreal, godot-waterways, source (docs/flowmaps.md)
    rf.bake_tiles(graph, "tiles", (10, 14))  # XYZ Web Mercator flow tiles + tiles.json

Names are imported lazily so that ``import riverflow`` stays cheap and never touches OpenGL.
"""
from __future__ import annotations

from importlib import import_module
from typing import Any

from riverflow.components.status import FlowStatus
from riverflow.hydro.graph import Area, Curve, CurveType, GraphError, HydroGraph

__version__ = "0.1.0"

_LAZY = {
    "load_graph": "riverflow.hydro.io",
    "save_graph": "riverflow.hydro.io",
    "validate_graph": "riverflow.hydro.validate",
    "ValidationIssue": "riverflow.hydro.validate",
    "RiverNetworkBuilder": "riverflow.hydro.builder",
    "FlowField": "riverflow.hydro.flow_field",
    "RiverWorld": "riverflow.engine.world",
    "RiverConfig": "riverflow.engine.config",
    "default_scene": "riverflow.scenes.default",
    "Scene": "riverflow.scenes.default",
    "landscape": "riverflow.scenes.landscape",
    "Landscape": "riverflow.scenes.landscape",
    "Obstacle": "riverflow.hydro.flow_field",
    "Boat": "riverflow.components.boat",
    "Wake": "riverflow.components.wake",
    "FoamSettings": "riverflow.components.foam",
    "DisplayMode": "riverflow.components.display",
    "DisplaySettings": "riverflow.components.display",
    "WaveKind": "riverflow.components.waves",
    "KeyScript": "riverflow.engine.controls",
    "FixedStep": "riverflow.engine.game_loop",
    "read_rivers": "riverflow.gis.rivers",
    "read_water": "riverflow.gis.water",
    "bake_flow_map": "riverflow.gis.bake",
    "bake_concentration": "riverflow.gis.spill",
    "Dispersion": "riverflow.hydro.spill_network",
    "bake_tiles": "riverflow.gis.tiles",
    "ResourceLimitError": "riverflow._validate",
    "set_memory_limit": "riverflow._validate",
    "memory_limit_bytes": "riverflow._validate",
    "ContextError": "riverflow.engine.gl",       # imports pyglet's GL: only when asked for
}

__all__ = ["FlowStatus", "Area", "Curve", "CurveType", "GraphError", "HydroGraph", *_LAZY]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'riverflow' has no attribute {name!r}")
    value = getattr(import_module(module), name)
    globals()[name] = value
    return value
