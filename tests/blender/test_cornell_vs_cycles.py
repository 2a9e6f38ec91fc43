"""The Cornell box in Glint against Cycles, tile by tile: Glint's own scene
files read by Blender's glTF importer, so Cycles renders what a user who
opened them would see, and Glint renders them back through the add-on.

The box is lit only by its ceiling emitter: strength 17, coloured (17, 12, 4)
W·sr⁻¹·m⁻², so it checks emission with strength > 1 and colour, and all the
light transport between diffuse walls (8 bounces). The diffuse variant has
every material at Specular IOR Level 0 and runs Glint's Lambert kernel; the
default one has the rough gold sphere and runs the Principled one. In the
hanging variant the diffuse box's lamp is lowered 29 cm, to 30 cm under
the ceiling: emitting from both faces as Cycles' mesh lights do, it lights
the ceiling above it, light landing near its emitter for which Glint
traces light subpaths (`--light-paths auto`), so that case is checked
against Cycles too."""

from pathlib import Path

import bpy
import numpy as np
import pytest
from helpers import render_seeds, tile_means

REPO = Path(__file__).resolve().parents[2]
SIZE, TILE = 32, 8
BOUNCES = 8
SAMPLES = 512
SEEDS = 3


def image_means(img):
    return img.mean(axis=(0, 1))


def difference(cycles, glint, means, pixels):
    """Cycles' and Glint's means over blocks of `pixels` pixels (`means`)
    and the standard error of their difference, from the per-pixel variance
    over the seeds (pixels are independent)."""
    def mean_and_error(images):
        stack = np.stack(images)
        return means(stack.mean(axis=0)), np.sqrt(means(stack.var(axis=0, ddof=1)) / (len(images) * pixels))

    (c, c_se), (g, g_se) = mean_and_error(cycles), mean_and_error(glint)
    return c, g, np.sqrt(c_se**2 + g_se**2)


def lower_lamp(scene, metres):
    """Moves the faces of the emitting material down (Blender's −Z)."""
    count = 0
    for obj in (o for o in scene.objects if o.type == "MESH"):
        mesh = obj.data
        lamp = {i for i, m in enumerate(mesh.materials) if m and m.name == "light"}
        moved = {v for p in mesh.polygons if p.material_index in lamp for v in p.vertices}
        for v in moved:
            mesh.vertices[v].co.z -= metres
        mesh.update()
        count += len(moved)
    # The lamp quad's corners: else the case would quietly be the plain box.
    assert count == 4, count


@pytest.mark.parametrize("name", ["cornell-box-diffuse", "cornell-box", "cornell-box-diffuse-hanging"])
def test_cornell_box_matches_cycles_per_tile(empty_scene, tmp_path, name):
    hanging = name.endswith("-hanging")
    bpy.ops.import_scene.gltf(filepath=str(REPO / "scenes" / f"{name.removesuffix('-hanging')}.gltf"))
    if hanging:
        lower_lamp(empty_scene, 0.29)
    empty_scene.camera = next(o for o in empty_scene.objects if o.type == "CAMERA")
    empty_scene.world = None
    empty_scene.render.resolution_x = empty_scene.render.resolution_y = SIZE
    empty_scene.view_settings.view_transform = "Standard"
    cycles, glint = render_seeds(empty_scene, tmp_path, SAMPLES, BOUNCES, SEEDS)
    c, g, se = difference(cycles, glint, lambda img: tile_means(img, TILE), TILE * TILE)
    z = np.abs(g - c) / np.maximum(se, 1e-9)
    ci, gi, image_se = difference(cycles, glint, image_means, SIZE * SIZE)
    bias, bias_z = gi / ci - 1, np.abs(gi - ci) / image_se
    print(f"{name}: bias against Cycles {np.round(bias * 100, 2)} % (R, G, B) ± {np.round(image_se / ci * 100, 2)}, "
          f"{bias_z.max():.1f} σ; worst tile {z.max():.1f} σ")
    # 16 tiles × 3 channels at 5 σ: a false alarm 1 time in 30,000, while
    # a 1% difference on a tile is well over 5 σ at this noise.
    assert z.max() < 5.0, (z.max(), bias)
    # The whole image is the sharpest check of a small overall bias.
    assert bias_z.max() < 5.0, (bias, bias_z)
