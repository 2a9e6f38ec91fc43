"""Point, spot and sun lights through Blender's glTF exporter (COMPAT units)
against Cycles: a Lambertian floor lit directly by one light, seen from
above, compared tile by tile. Cycles is set up with the lights punctual
(radius 0, soft falloff off, sun angle 0), as Glint renders them."""

import math

import bpy
import numpy as np
import pytest
from helpers import add_camera, fair_cycles, give_principled, read_exr

SIZE, TILE = 32, 8


def floor_and_camera(scene):
    bpy.ops.mesh.primitive_plane_add(size=100)
    give_principled(bpy.context.object, "Floor", Base_Color=(0.5, 0.5, 0.5, 1), Roughness=1.0, Specular_IOR_Level=0.0)
    add_camera(scene, (0, 0, 6), lens=18)  # a 12 m wide view of the floor
    scene.world = None
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.view_settings.view_transform = "Standard"


def add_light(scene, kind):
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
    scene.collection.objects.link(obj)


def render(scene, engine, seed, path):
    if engine == "CYCLES":
        fair_cycles(scene, 64, 0, seed)
    else:
        scene.render.engine = engine
        scene.glint.samples, scene.glint.max_bounces, scene.glint.seed = 64, 0, seed
    bpy.ops.render.render()
    bpy.data.images["Render Result"].save_render(str(path))
    return read_exr(path)[..., :3].astype(np.float64)


def tile_means(img):
    return img.reshape(SIZE // TILE, TILE, SIZE // TILE, TILE, 3).mean(axis=(1, 3))


@pytest.mark.parametrize("kind", ["POINT", "SPOT", "SUN"])
def test_punctual_light_on_a_floor_matches_cycles(empty_scene, tmp_path, kind):
    floor_and_camera(empty_scene)
    add_light(empty_scene, kind)
    c1, c2 = (render(empty_scene, "CYCLES", s, tmp_path / f"c{s}.exr") for s in (1, 2))
    g1, g2 = (render(empty_scene, "GLINT", s, tmp_path / f"g{s}.exr") for s in (1, 2))
    c, g = tile_means((c1 + c2) / 2), tile_means((g1 + g2) / 2)
    n = TILE * TILE
    se = np.sqrt((tile_means((c1 - c2) ** 2) + tile_means((g1 - g2) ** 2)) / 2 / (2 * n))
    # Per sample both renderers evaluate the same closed form, so the noise
    # is small (pixel jitter across the light's falloff); 0.2% of the tile
    # covers single-precision arithmetic on both sides.
    tol = 5 * se + 2e-3 * c
    print(f"{kind}: mean Glint/Cycles − 1 = {g.sum() / c.sum() - 1:+.4%}, worst tile {np.max(np.abs(g - c) / np.maximum(tol, 1e-12)):.2f} of tolerance")
    assert c.mean() > 0.01
    assert np.all(np.abs(g - c) <= tol), (np.round(g[..., 0], 4), np.round(c[..., 0], 4))
