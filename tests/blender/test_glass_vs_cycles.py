"""Glass in Glint against Cycles: a Principled BSDF with Transmission
Weight 1 on a smooth sphere standing on a two-coloured floor under a plain
World, perfectly smooth and at roughness 0.3 (tinted), the exporter writing
KHR_materials_transmission and KHR_materials_ior. Cycles renders the
glass's caustics and shadows along BSDF paths as Glint does (shadow rays
stop at glass in both), so the whole image is compared: per 8 × 8 tile
within 5 combined standard errors, two seeds a side."""

import math

import bpy
import numpy as np
import pytest
from helpers import add_camera, give_principled, plain_world
from test_addon import glb_json
from test_textures_vs_cycles import compare

# Light refracts through two surfaces per crossing and reflects inside:
# 16 bounces leave < 0.1% of it behind in both renderers.
BOUNCES = 16


@pytest.mark.parametrize("roughness, colour, ior", [(0.0, (1.0, 1.0, 1.0), 1.5), (0.3, (0.9, 0.75, 0.5), 1.45)])
def test_glass_sphere_matches_cycles(empty_scene, tmp_path, roughness, colour, ior):
    plain_world(empty_scene, (0.8, 0.85, 0.9))
    for x, tint in [(-2.0, (0.8, 0.2, 0.1, 1.0)), (2.0, (0.1, 0.3, 0.8, 1.0))]:
        bpy.ops.mesh.primitive_plane_add(size=4.0, location=(x, 0, 0))
        give_principled(bpy.context.object, f"Floor {x}", Base_Color=tint, Roughness=0.8)
    bpy.ops.mesh.primitive_uv_sphere_add(segments=64, ring_count=32, radius=0.8, location=(0, 0, 0.8))
    bpy.ops.object.shade_smooth()
    give_principled(bpy.context.object, "Glass", Base_Color=(*colour, 1.0), Roughness=roughness, Transmission_Weight=1.0, IOR=ior)
    add_camera(empty_scene, (0, -4.0, 1.6), (math.radians(80), 0, 0), lens=50)
    empty_scene.render.resolution_x = empty_scene.render.resolution_y = 32
    empty_scene.view_settings.view_transform = "Standard"

    z, bias = compare(empty_scene, tmp_path, 128, BOUNCES)
    from glint import daemon

    glass = next(m for m in glb_json(daemon.current().path("scene.glb"))["materials"] if m["name"] == "Glass")
    assert glass["extensions"]["KHR_materials_transmission"]["transmissionFactor"] == 1.0
    assert abs(glass["extensions"].get("KHR_materials_ior", {"ior": 1.5})["ior"] - ior) < 1e-6
    print(f"glass, roughness {roughness}: bias against Cycles {np.round(bias * 100, 2)} %, worst tile {z.max():.1f} σ")
    assert z.max() < 5.0, (z.max(), bias)
