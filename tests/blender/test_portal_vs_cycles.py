"""A room lit only by the World through a window, with a Cycles light
portal in the window (an area light marked Portal, its power set high): in
Glint against Cycles. A portal gives no light of its own in Cycles; it
only guides the sampling of the World. Glint must agree with Cycles per
8 × 8 tile within 5 combined standard errors (two seeds a side), so that a
portal taken for a lamp (as the add-on sent it before: 500 W in the
window) or sampling through it that is biased would show."""

import math

import bpy
from helpers import add_camera, plain_world, render_seeds, tile_agreement

SIZE, TILE, BOUNCES, SAMPLES = 32, 8, 6, 256


def wall_material():
    """White Lambert (Specular IOR Level 0) in both renderers."""
    material = bpy.data.materials.new("Wall")
    material.use_nodes = True
    bsdf = material.node_tree.nodes["Principled BSDF"]
    bsdf.inputs["Base Color"].default_value = (0.8, 0.8, 0.8, 1.0)
    bsdf.inputs["Roughness"].default_value = 1.0
    bsdf.inputs["Specular IOR Level"].default_value = 0.0
    return material


def box(lo, hi, material):
    """An axis-aligned box from corner `lo` to corner `hi` (metres)."""
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=[(a + b) / 2 for a, b in zip(lo, hi)])
    obj = bpy.context.object
    obj.scale = [b - a for a, b in zip(lo, hi)]
    obj.data.materials.append(material)


def room_with_a_window(scene):
    """A 4 × 4 × 3 m room of 10 cm walls whose +X wall has a window 1.2 m
    wide and 1 m high (y in ±0.6, z from 1 to 2), a portal in it facing
    the room (the light's −Z along −X), a grey World, and a camera in a
    corner looking at the window wall and the floor it lights."""
    m = wall_material()
    box((-2.1, -2.1, -0.1), (2.1, 2.1, 0.0), m)  # floor
    box((-2.1, -2.1, 3.0), (2.1, 2.1, 3.1), m)  # ceiling
    box((-2.1, -2.1, 0.0), (-2.0, 2.1, 3.0), m)  # −X wall
    box((-2.0, -2.1, 0.0), (2.0, -2.0, 3.0), m)  # −Y wall
    box((-2.0, 2.0, 0.0), (2.0, 2.1, 3.0), m)  # +Y wall
    # The +X wall around the window.
    box((2.0, -2.1, 0.0), (2.1, 2.1, 1.0), m)
    box((2.0, -2.1, 2.0), (2.1, 2.1, 3.0), m)
    box((2.0, -2.1, 1.0), (2.1, -0.6, 2.0), m)
    box((2.0, 0.6, 1.0), (2.1, 2.1, 2.0), m)
    light = bpy.data.lights.new("Portal", "AREA")
    light.shape, light.size, light.size_y, light.energy = "RECTANGLE", 1.0, 1.2, 500.0
    light.cycles.is_portal = True
    portal = bpy.data.objects.new("Portal", light)
    # Turned 90° about Y: local Z to +X, so its −Z looks into the room;
    # local X (1 m) runs along Z, local Y (1.2 m) along Y.
    portal.location, portal.rotation_euler = (2.05, 0.0, 1.5), (0.0, math.radians(90), 0.0)
    scene.collection.objects.link(portal)
    plain_world(scene, (0.9, 0.95, 1.0), strength=2.0)
    add_camera(scene, (-1.8, -1.6, 1.6), rotation=(math.radians(80), 0.0, math.radians(-64)), lens=18)
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.view_settings.view_transform = "Standard"


def test_room_lit_through_a_portal_matches_cycles(empty_scene, tmp_path):
    room_with_a_window(empty_scene)
    cycles, glint = render_seeds(empty_scene, tmp_path, SAMPLES, BOUNCES, 2)
    z, bias = tile_agreement(cycles, glint, TILE)
    print(f"portal: worst tile {z.max():.1f} σ, bias {bias * 100} %")
    assert z.max() < 5.0, (z.max(), bias)
    # The room is lit: a portal that blocked the window, or a World left
    # black, would pass the tiles only by being dark in both.
    assert min(c.mean() for c in cycles) > 0.05
