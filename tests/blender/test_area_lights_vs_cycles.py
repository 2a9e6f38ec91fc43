"""Blender area lights through the add-on against Cycles itself: a floor lit
only directly (no bounces) by each light shape, seen through a narrow camera
so every pixel estimates the same irradiance. Cycles' convention is radiance
P/(π·A) from the front face; Glint's lamps must give the same floor."""

import math
import subprocess

import bpy
import numpy as np
import pytest
from helpers import add_camera, fair_cycles, give_principled, plain_world, read_exr, render_seeds, tile_agreement, two_seeds_by_tile


def scene_with_light(scene, shape, rotation):
    bpy.ops.mesh.primitive_plane_add(size=200)
    # Specular IOR Level 0: pure Lambert in both renderers.
    give_principled(bpy.context.object, "Floor", Base_Color=(0.5, 0.5, 0.5, 1), Roughness=1.0, Specular_IOR_Level=0.0)
    light = bpy.data.lights.new("Lamp", "AREA")
    light.shape, light.size, light.size_y, light.energy = shape, 1.0, 0.5, 50.0
    light.color = (1.0, 0.6, 0.3)
    lamp = bpy.data.objects.new("Lamp", light)
    lamp.location, lamp.rotation_euler = (0.2, -0.1, 1.0), rotation
    scene.collection.objects.link(lamp)
    add_camera(scene, (0, 0, 3), lens=2000)  # a 2 cm spot on the floor
    scene.world = None
    scene.render.resolution_x = scene.render.resolution_y = 16


def mean_and_error(path):
    rgb = read_exr(path)[..., :3].reshape(-1, 3).astype(np.float64)
    return rgb.mean(axis=0), rgb.std(axis=0) / math.sqrt(len(rgb))


@pytest.mark.parametrize(
    "shape, rotation",
    [("SQUARE", (0, 0, 0)), ("RECTANGLE", (0.3, 0.2, 0.5)), ("DISK", (0, 0, 0)), ("ELLIPSE", (-0.4, 0, 1.0))],
)
def test_area_light_lights_the_floor_as_in_cycles(empty_scene, tmp_path, shape, rotation):
    scene = empty_scene
    scene_with_light(scene, shape, rotation)
    scene.view_settings.view_transform = "Standard"
    fair_cycles(scene, 256, 0)
    bpy.ops.render.render()
    bpy.data.images["Render Result"].save_render(str(tmp_path / "cycles.exr"))
    scene.render.engine = "GLINT"
    scene.glint.samples, scene.glint.max_bounces = 256, 0
    bpy.ops.render.render()
    bpy.data.images["Render Result"].save_render(str(tmp_path / "glint.exr"))
    (cm, ce), (gm, ge) = mean_and_error(tmp_path / "cycles.exr"), mean_and_error(tmp_path / "glint.exr")
    print(f"{shape}: Cycles {cm} ± {ce}, Glint {gm} ± {ge}")
    # Both are unbiased estimates of one irradiance: they must agree within
    # 5 combined standard errors (each about 0.1–0.3% here).
    assert np.all(np.abs(cm - gm) < 5 * np.sqrt(ce**2 + ge**2)), (cm, gm, ce, ge)
    assert cm[0] > 0.1


SIZE, TILE, SPP = 32, 4, 128


@pytest.mark.parametrize(
    "spread_degrees, tilt, metallic, roughness, shape",
    [(60, 0.0, 0.0, 1.0, "RECTANGLE"), (30, 0.5, 0.0, 1.0, "RECTANGLE"), (90, 0.3, 1.0, 0.3, "RECTANGLE"), (40, 0.3, 0.0, 1.0, "ELLIPSE")],
)
def test_a_spread_narrows_the_light_as_in_cycles(empty_scene, tmp_path, spread_degrees, tilt, metallic, roughness, shape):
    """An area light's Spread (a softbox grid: Cycles' attenuation
    (tan h − tan θ)/(tan h − h), h half the spread) on a floor seen from
    above, lit directly: the bright patch under the lamp and the dark
    beyond its cone, tile by tile; on a glossy metal floor the lamp is also
    seen by BSDF rays, MIS-weighted against its light samples; an ellipse
    lamp too. Both draw light samples only from the part of the lamp a
    point sees through the grid."""
    scene = empty_scene
    bpy.ops.mesh.primitive_plane_add(size=100)
    give_principled(bpy.context.object, "Floor", Base_Color=(0.5, 0.5, 0.5, 1), Metallic=metallic, Roughness=roughness, Specular_IOR_Level=0.0)
    light = bpy.data.lights.new("Softbox", "AREA")
    light.shape, light.size, light.size_y, light.energy = shape, 1.0, 0.6, 200.0
    light.spread = math.radians(spread_degrees)
    lamp = bpy.data.objects.new("Softbox", light)
    lamp.location, lamp.rotation_euler = (0.3, -0.2, 1.5), (tilt, 0.0, 0.4)
    scene.collection.objects.link(lamp)
    add_camera(scene, (0, 0, 6), lens=30)  # a 7 m wide view of the floor, 0.9 m tiles
    scene.world = None
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.view_settings.view_transform = "Standard"
    _, _, c, g, se = two_seeds_by_tile(scene, tmp_path, SPP, 0, TILE)
    # Two unbiased estimates of each tile: within 5 combined standard
    # errors (the noise from two seeds each side), plus 0.5% of the tile
    # for single-precision sums and the pixels' stratified jitter over the
    # patch's edge, plus 0.1% of the brightest tile: at the cone's rim the
    # attenuation falls to 0, and a tile there gets a few pixels' light from
    # the last sliver of the lamp, samples rare enough that two seeds do
    # not measure their noise (0.0004 against 0 in a tile where the
    # brightest holds 20).
    tol = 5 * se + 5e-3 * c + 1e-3 * c.max()
    print(f"spread {spread_degrees}° ({shape.lower()}): mean Glint/Cycles − 1 = {g.sum() / c.sum() - 1:+.4%}, worst tile {np.max(np.abs(g - c) / np.maximum(tol, 1e-12)):.2f} of tolerance")
    assert c.max() > 0.05
    # The cone leaves some of the floor in view unlit: a lamp without a
    # Spread lights every tile.
    assert (c.max(axis=2) < 1e-4 * c.max()).any() and (g.max(axis=2) < 1e-4 * g.max()).any()
    worst = np.unravel_index(np.argmax(np.abs(g - c) / np.maximum(tol, 1e-12)), tol.shape)
    assert np.all(np.abs(g - c) <= tol), (worst, g[worst[:2]], c[worst[:2]], tol[worst[:2]], se[worst[:2]])


def test_an_open_corner_matches_cycles(empty_scene, tmp_path, executable):
    """A matte ball in the corner of two walls on a floor, lit by a 0.6 m
    area light 3 m up and a dim World, 8 bounces, tile by tile against
    Cycles: a scene open to the World on some sides, for which
    `--light-paths auto` traces light subpaths (their connections and light
    tracing carry most of the walls' and floor's indirect light there). The
    exported scene's features line must say so, or the case would quietly
    be the path tracer's alone."""
    import glint.export as export

    scene = empty_scene
    matte = {"Base_Color": (0.8, 0.8, 0.8, 1), "Roughness": 1.0, "Specular_IOR_Level": 0.0}
    bpy.ops.mesh.primitive_plane_add(size=20)
    give_principled(bpy.context.object, "Floor", **{**matte, "Base_Color": (0.5, 0.5, 0.5, 1)})
    bpy.ops.mesh.primitive_plane_add(size=6, location=(0, 2.0, 3.0), rotation=(math.radians(90), 0, 0))
    give_principled(bpy.context.object, "Back", **matte)
    bpy.ops.mesh.primitive_plane_add(size=6, location=(-2.0, 0, 3.0), rotation=(0, math.radians(90), 0))
    give_principled(bpy.context.object, "Side", **matte)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=0.4, location=(0.6, 0.3, 0.4), segments=32, ring_count=16)
    give_principled(bpy.context.object, "Ball", **matte)
    light = bpy.data.lights.new("Key", "AREA")
    light.size, light.energy = 0.6, 400.0
    lamp = bpy.data.objects.new("Key", light)
    lamp.location, lamp.rotation_euler = (0.3, -0.2, 3.0), (0.3, 0.0, 0.4)
    scene.collection.objects.link(lamp)
    add_camera(scene, (0, -4.5, 3.5), (math.radians(50), 0, 0), lens=30)
    plain_world(scene, (0.05, 0.05, 0.05))
    scene.render.resolution_x = scene.render.resolution_y = 32
    scene.view_settings.view_transform = "Standard"
    cycles, glint = render_seeds(scene, tmp_path, 256, 8, 3)

    export.export_scene(str(tmp_path / "scene.glb"), scene.frame_current, scene.frame_subframe)
    request, _ = export.render_request(bpy.context.evaluated_depsgraph_get(), "check", 8, 8)
    (tmp_path / "request.json").write_bytes(export.json_bytes(request))
    out = subprocess.run([executable, "render", str(tmp_path / "scene.glb"), "--request", str(tmp_path / "request.json"), "--spp", "1",
                          "-o", str(tmp_path / "check.exr")], check=True, capture_output=True, text=True)
    features = out.stderr.splitlines()[0]
    assert features.endswith("+ light paths"), features

    z, bias = tile_agreement(cycles, glint, 8)
    print(f"open corner: bias against Cycles {np.round(bias * 100, 2)} % (R, G, B), worst tile {z.max():.1f} σ")
    # 16 tiles × 3 channels at 5 σ, as the Cornell box's test: a false
    # alarm 1 time in 30,000.
    assert z.max() < 5.0, (z.max(), bias)
    assert np.all(np.abs(bias) < 0.02), bias
