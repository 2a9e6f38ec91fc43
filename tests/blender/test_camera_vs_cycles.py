"""Where a pixel looks, in Glint and in Cycles: a sub-pixel offset of the
camera would shift every edge and highlight, and at 64 spp it hides in the
noise of the image comparisons. Here the corner of an emissive plane sits
at a known fraction of a pixel, so each edge pixel's value is the share of
the pixel the plane covers."""

import bpy
import numpy as np
from helpers import add_camera, give_principled, render_seeds

SIZE, DISTANCE, LENS = 32, 10.0, 50.0
PIXEL = 2 * DISTANCE * 18 / LENS / SIZE  # metres per pixel on the plane (36 mm sensor)


def test_edge_pixels_cover_what_the_plane_covers(empty_scene, tmp_path):
    """The plane starts 0.3 pixel right of the image centre and 0.7 pixel
    above it, so the pixel right of the centre column is 70% covered, the
    one above the centre row 30%, their corner 21%. Cycles' stratified
    samples give these within 1e-3; Glint's independent samples are binomial
    noise, √(p(1−p)/N) ≤ 0.004 at 2 × 8,192 spp: a 5 σ tolerance catches an
    offset of 0.03 pixel."""
    x0, y0 = 0.3 * PIXEL, 0.7 * PIXEL
    mesh = bpy.data.meshes.new("Plane")
    mesh.from_pydata([(x0, y0, 0), (50, y0, 0), (50, 50, 0), (x0, 50, 0)], [], [(0, 1, 2, 3)])
    plane = bpy.data.objects.new("Plane", mesh)
    empty_scene.collection.objects.link(plane)
    give_principled(plane, "Emitter", Base_Color=(0, 0, 0, 1), Emission_Color=(1, 1, 1, 1),
                    Emission_Strength=1.0, Specular_IOR_Level=0.0)
    add_camera(empty_scene, (0, 0, DISTANCE), lens=LENS)  # looking down −Z
    empty_scene.render.resolution_x = empty_scene.render.resolution_y = SIZE
    empty_scene.view_settings.view_transform = "Standard"
    samples, seeds = 8192, 2
    cycles, glint = render_seeds(empty_scene, tmp_path, samples, 1, seeds)
    c, g = np.mean(cycles, 0)[..., 0], np.mean(glint, 0)[..., 0]
    # Rows are bottom first: row 16 spans [0, 1] pixel above the centre.
    h = SIZE // 2
    expected = {(h + 1, h): 0.7, (h + 2, h): 0.7, (h, h + 1): 0.3, (h, h + 2): 0.3, (h, h): 0.21,
                (h - 1, h): 0.0, (h + 1, h - 1): 0.0, (h + 1, h + 1): 1.0}
    for (row, col), p in expected.items():
        tolerance = 5 * np.sqrt(p * (1 - p) / (samples * seeds)) + 1e-4
        assert abs(c[row, col] - p) < 1e-3, ("Cycles", row, col, c[row, col], p)
        assert abs(g[row, col] - p) < tolerance, ("Glint", row, col, g[row, col], p, tolerance)
