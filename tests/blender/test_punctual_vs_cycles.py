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


def assert_agree(scene, tmp_path, what, bounces=0):
    (c1, c2), (g1, g2), c, g, se = two_seeds_by_tile(scene, tmp_path, SPP, bounces, TILE)
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
    quantum = np.maximum((c1 + c2).max(axis=(0, 1)), (g1 + g2).max(axis=(0, 1))) / 2 / SPP / n
    tol = 5 * se + 2e-3 * c + 2 * quantum
    print(f"{what}: mean Glint/Cycles − 1 = {g.sum() / c.sum() - 1:+.4%}, worst tile {np.max(np.abs(g - c) / np.maximum(tol, 1e-12)):.2f} of tolerance")
    assert c.mean() > 0.01
    worst = np.unravel_index(np.argmax(np.abs(g - c) / tol), tol.shape)
    assert np.all(np.abs(g - c) <= tol), (worst, g[worst[:2]], c[worst[:2]], tol[worst[:2]])


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