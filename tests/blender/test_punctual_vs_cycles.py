"""Point, spot and sun lights through Blender's glTF exporter (COMPAT units)
against Cycles: a Lambertian floor lit directly by one light, seen from
above, compared tile by tile. Each light is punctual (radius 0, sun angle
0) and then sized as Blender users leave it: a radius with Soft Falloff
(Blender's default, a disk facing the point it lights), a radius without
(a sphere), a sun with an angle. The add-on passes the sizes in the
request. A pole on the floor casts the shadow whose penumbra the size
makes."""

import math

import bpy
import numpy as np
import pytest
from helpers import add_camera, give_principled, two_seeds_by_tile

SIZE, TILE = 32, 4
SPP = 64


def floor_and_camera(scene):
    bpy.ops.mesh.primitive_plane_add(size=100)
    give_principled(bpy.context.object, "Floor", Base_Color=(0.5, 0.5, 0.5, 1), Roughness=1.0, Specular_IOR_Level=0.0)
    add_camera(scene, (0, 0, 6), lens=30)  # a 7 m wide view of the floor, 0.9 m tiles
    scene.world = None
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.view_settings.view_transform = "Standard"


def add_light(scene, kind, size):
    """`size`: None for punctual, else ("soft" | "sphere", radius) or, for
    the sun, ("angle", radians)."""
    light = bpy.data.lights.new(kind, kind)
    light.color = (1.0, 0.8, 0.6)
    obj = bpy.data.objects.new(kind, light)
    if kind == "POINT":
        light.energy, light.shadow_soft_size = 500.0, 0.0
        light.use_soft_falloff = False
        obj.location = (1.0, 0.5, 2.0)
    elif kind == "SPOT":
        light.energy, light.shadow_soft_size = 2000.0, 0.0
        light.use_soft_falloff = False
        light.spot_size, light.spot_blend = math.radians(70), 0.4
        obj.location = (-0.5, 0.0, 3.0)
        obj.rotation_euler = (math.radians(20), 0, 0)
    else:
        light.energy, light.angle = 3.0, 0.0
        obj.rotation_euler = (math.radians(50), 0, math.radians(30))
    if size and kind == "SUN":
        light.angle = size[1]
    elif size:
        light.shadow_soft_size, light.use_soft_falloff = size[1], size[0] == "soft"
    scene.collection.objects.link(obj)


SIZES = [
    ("POINT", None),
    ("SPOT", None),
    ("SUN", None),
    ("POINT", ("soft", 0.5)),
    ("POINT", ("sphere", 0.5)),
    ("SPOT", ("soft", 0.3)),
    ("SUN", ("angle", math.radians(30))),
]


@pytest.mark.parametrize("kind, size", SIZES)
def test_punctual_light_on_a_floor_matches_cycles(empty_scene, tmp_path, kind, size):
    floor_and_camera(empty_scene)
    # A thin pole: its shadow is a line under a punctual light and spreads
    # over tiles under a sized one.
    bpy.ops.mesh.primitive_cube_add(size=1.0, location=(0.3, 0.2, 1.0), scale=(0.2, 0.2, 2.0))
    give_principled(bpy.context.object, "Pole", Base_Color=(0.5, 0.5, 0.5, 1), Roughness=1.0, Specular_IOR_Level=0.0)
    add_light(empty_scene, kind, size)
    assert_agree(empty_scene, tmp_path, f"{kind} {size}")


def assert_agree(scene, tmp_path, what, bounces=0, samples=SPP):
    (c1, c2), (g1, g2), c, g, se = two_seeds_by_tile(scene, tmp_path, samples, bounces, TILE)
    n = TILE * TILE
    # A punctual light is the same closed form per sample in both, so the
    # noise is small (pixel jitter across the falloff and the shadow's
    # edge); 0.2% of the tile covers single-precision arithmetic on both
    # sides. A sized light adds its sampling noise to se. Both renderers
    # stratify a pixel's jitter (Sobol points), so where a sharp edge (a
    # sun's disk in a mirror) crosses a pixel, every seed covers it with
    # the same count of samples and their spread reads as nil: each count
    # is resolved to one sample, so two renderers' may differ by two
    # samples of the brightest pixel (measured: 15 against 14 of 64 on the
    # sun's edge, the same in both seeds of each).
    quantum = np.maximum((c1 + c2).max(axis=(0, 1)), (g1 + g2).max(axis=(0, 1))) / 2 / samples / n
    tol = 5 * se + 2e-3 * c + 2 * quantum
    print(f"{what}: mean Glint/Cycles − 1 = {g.sum() / c.sum() - 1:+.4%}, worst tile {np.max(np.abs(g - c) / np.maximum(tol, 1e-12)):.2f} of tolerance")
    assert c.mean() > 0.01
    worst = np.unravel_index(np.argmax(np.abs(g - c) / tol), tol.shape)
    assert np.all(np.abs(g - c) <= tol), (worst, g[worst[:2]], c[worst[:2]], tol[worst[:2]])
    return c, g, se


SEEN = [
    ("POINT", ("soft", 0.5), 0.0, False),
    ("POINT", ("sphere", 0.5), 0.15, False),
    ("SPOT", ("soft", 0.4), 0.0, False),
    ("SUN", ("angle", math.radians(10)), 0.0, False),
    ("POINT", ("sphere", 0.3), 0.3, True),
]


@pytest.mark.parametrize("kind, size, roughness, visible_camera", SEEN)
def test_sized_lights_seen_in_a_metal_floor_match_cycles(empty_scene, tmp_path, kind, size, roughness, visible_camera):
    """Blender's lights are seen by BSDF rays (not by the camera, unless its
    Visibility › Camera is ticked): a mirror or a glossy metal floor shows
    a sized lamp, a disk of radiance I/(πr²) or a sun's disk; Glint's BSDF
    rays must reach it, MIS-weighted against the light's samples."""
    floor_and_camera(empty_scene)
    floor = bpy.context.scene.objects["Plane"]
    floor.data.materials.clear()
    give_principled(floor, "Metal", Base_Color=(0.9, 0.9, 0.9, 1), Metallic=1.0, Roughness=roughness)
    add_light(empty_scene, kind, size)
    light = empty_scene.objects[kind]
    light.visible_camera = visible_camera
    if kind == "SUN":
        light.rotation_euler = (math.radians(15), 0, math.radians(30))  # its reflection in view
    elif kind == "SPOT":
        light.rotation_euler = (0, 0, 0)
        light.data.spot_size = math.radians(120)
    assert_agree(empty_scene, tmp_path, f"{kind} {size} roughness {roughness}, camera {visible_camera}", bounces=1)


@pytest.mark.parametrize("kind", ["POINT", "SPOT"])
def test_a_bulbs_light_thrown_by_a_metal_plate_matches_cycles(empty_scene, tmp_path, kind):
    """A bulb (Blender's default point light: 0.1 m, Soft Falloff) under a
    rough metal plate out of view, a black card below the bulb keeping its
    own light off the floor: the plate throws the bulb's light onto the
    Lambertian floor the camera sees. The plate focuses light, so Glint
    traces light subpaths from the bulb (light_paths.rs), and they carry
    much of that patch (light tracing from the floor, connections), MIS-
    weighted against the camera paths' light samples at the plate and
    their BSDF rays that meet the bulb; Cycles finds it by camera paths
    alone. Both must render the same floor, tile by tile (`assert_agree`)
    and over the whole image, whose mean's standard error (about 0.35% at
    4,096 samples, mostly Cycles') resolves a bias of 2%. The same of a
    spot (60°, blend 0.3) of the same radius shining up at the plate.
    Measured: Glint +0.65% and +1.03% (1.9 σ each); with the sized
    light's connection density off by a factor π (integrator.rs), the
    bulb's −3.0% (8.7 σ), and the test fails — the spot's moves by 0.05%:
    its connections carry nearly all of the thrown light, and that error
    only weighs its light samples, which then count for nearly nothing
    (`tests/render.rs` catches it there: −17%)."""
    floor_and_camera(empty_scene)
    # Its normal (0.29, 0, −0.96): the bulb's light, rising to it, leaves
    # down and to the right, onto the middle of the view.
    bpy.ops.mesh.primitive_plane_add(size=1.5, location=(-3.0, 0.0, 2.5), rotation=(0.0, math.radians(163.4), 0.0))
    give_principled(bpy.context.object, "Plate", Base_Color=(0.95, 0.9, 0.85, 1), Metallic=1.0, Roughness=0.25)
    # A black card under the bulb keeps its own light off the floor.
    bpy.ops.mesh.primitive_plane_add(size=2.0, location=(-3.4, 0.0, 0.3))
    give_principled(bpy.context.object, "Card", Base_Color=(0.0, 0.0, 0.0, 1), Roughness=1.0, Specular_IOR_Level=0.0)
    light = bpy.data.lights.new("Bulb", kind)
    light.energy, light.shadow_soft_size = 300.0, 0.1
    bulb = bpy.data.objects.new("Bulb", light)
    bulb.location = (-3.4, 0.0, 0.5)
    if kind == "SPOT":
        light.spot_size, light.spot_blend = math.radians(60), 0.3
        bulb.rotation_euler = (math.pi, 0.0, 0.0)  # its −Z up
    empty_scene.collection.objects.link(bulb)
    c, g, se = assert_agree(empty_scene, tmp_path, f"a {kind.lower()}'s light thrown by a plate", bounces=2, samples=4096)
    # The whole floor's mean, whose standard error is the tiles' over √64:
    # a bias of a few percent that no single tile resolves shows here.
    se_mean = np.sqrt((se**2).sum(axis=(0, 1))) / (se.shape[0] * se.shape[1])
    diff = g.mean(axis=(0, 1)) - c.mean(axis=(0, 1))
    print(f"whole image: Glint − Cycles {diff} (se {se_mean}, mean {c.mean(axis=(0, 1))})")
    assert np.all(np.abs(diff) <= 5 * se_mean + 2e-3 * c.mean(axis=(0, 1))), (diff, se_mean)
