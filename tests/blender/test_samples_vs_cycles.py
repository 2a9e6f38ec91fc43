"""The Khronos sample models (../shared/gltf-samples) in Glint against
Cycles: an outside test of how Glint reads glTF. Cycles renders each model
as Blender's own glTF importer reads it; Glint renders the same file
itself (not through the add-on, whose exporter would hand it Blender's
reading back). What the two disagree on — node orientation, texture
coordinates and wrap modes, vertex colours, two UV sets, factors ×
textures, emission — shows as tiles that differ.

Each model is seen by a camera added to a copy of its file, framing its
bounds from the front, a little above and to the right; both read that
camera from the file. A grey World lights it (0.8, Blender's default
surface grey). Primitives without a material render with Blender's default
surface (Cycles' grey diffuse; Glint's request `default_surface`), except
where the importer makes one of its own: a vertex-coloured primitive
without a material becomes the importer's DefaultMaterial (base colour =
COLOR_0, metallic 0, roughness 0.5), so the copy states that material.

Tolerance: every 8 × 8 tile within 5 combined standard errors (the noise
from two seeds a side), as in the other comparisons: a systematic
difference of a texel row, a mirrored texture or a wrong colour attribute
moves whole tiles by far more."""

import json
import math
import os
import subprocess
from pathlib import Path

import bpy
import numpy as np
import pytest
from helpers import fair_cycles, new_empty_scene, plain_world, read_exr, render_rgb, tile_agreement
from mathutils import Matrix, Vector

SIZE, TILE, SAMPLES, SEEDS, BOUNCES = 64, 8, 32, 8, 4
# These two face −Z: their textures are seen from behind.
FROM_BEHIND = {"TextureCoordinateTest", "TextureSettingsTest"}
WORLD = (0.8, 0.8, 0.8)
SHARED = Path(os.environ.get("GLINT_SHARED_DIR", Path(__file__).resolve().parents[3] / "shared"))
MODELS = sorted(p.name for p in (SHARED / "gltf-samples").iterdir() if p.is_dir()) if (SHARED / "gltf-samples").is_dir() else []


def bounds_in_gltf_axes():
    """The imported meshes' world bounds, in glTF's axes (Y up): the
    importer turned glTF (x, y, z) into Blender's (x, −z, y)."""
    corners = [o.matrix_world @ Vector(c) for o in bpy.context.scene.objects if o.type == "MESH" for c in o.bound_box]
    points = np.array([(p.x, p.z, -p.y) for p in corners])
    return points.min(axis=0), points.max(axis=0)


def with_camera(source, target, lo, hi, behind):
    """A copy of glTF file `source` with a camera node "TestCamera" whose
    50 mm view holds the bounds' sphere, and the importer's DefaultMaterial
    for vertex-coloured primitives without one."""
    doc = json.loads(source.read_text(encoding="utf-8"))
    centre, radius = (lo + hi) / 2, np.linalg.norm(hi - lo) / 2
    yfov = 2 * math.atan(18 / 50)
    back = Vector((0.35, 0.45, -1.0 if behind else 1.0)).normalized()
    eye = Vector(centre) + back * (1.02 * radius / math.sin(yfov / 2))
    right = Vector((0.0, 1.0, 0.0)).cross(back).normalized()
    turn = Matrix((right, back.cross(right), back)).transposed().to_quaternion()
    doc.setdefault("cameras", []).append({"type": "perspective", "perspective": {"yfov": yfov, "aspectRatio": 1.0, "znear": 0.01 * radius}})
    doc.setdefault("nodes", []).append({"name": "TestCamera", "camera": len(doc["cameras"]) - 1,
                                        "translation": list(eye), "rotation": [turn.x, turn.y, turn.z, turn.w]})
    doc["scenes"][doc.get("scene", 0)]["nodes"].append(len(doc["nodes"]) - 1)
    for mesh in doc.get("meshes", []):
        for prim in mesh["primitives"]:
            if "material" not in prim and "COLOR_0" in prim["attributes"]:
                doc.setdefault("materials", []).append(
                    {"name": "DefaultMaterial", "pbrMetallicRoughness": {"metallicFactor": 0.0, "roughnessFactor": 0.5}})
                prim["material"] = len(doc["materials"]) - 1
    target.write_text(json.dumps(doc), encoding="utf-8")


def glint_seeds(executable, scene, tmp_path, seeds):
    request = tmp_path / "request.json"
    request.write_text(json.dumps({"default_surface": list(WORLD)}))
    images = []
    for seed in range(1, seeds + 1):
        out = tmp_path / f"g{seed}.exr"
        subprocess.run([executable, "render", str(scene), "-o", str(out), "--request", str(request),
                        "--camera", "TestCamera", "--spp", str(SAMPLES), "--seed", str(seed),
                        "--width", str(SIZE), "--height", str(SIZE), "--max-depth", str(BOUNCES + 1),
                        "--background", *map(str, WORLD)], check=True, capture_output=True)
        images.append(read_exr(out)[..., :3].astype(np.float64))
    return images


@pytest.mark.skipif(not MODELS, reason=f"the sample models are missing from {SHARED}")
@pytest.mark.parametrize("name", MODELS)
def test_sample_model_matches_cycles(empty_scene, tmp_path, executable, name):
    source = SHARED / "gltf-samples" / name / f"{name}.gltf"
    bpy.ops.import_scene.gltf(filepath=str(source))
    lo, hi = bounds_in_gltf_axes()
    scene_file = tmp_path / f"{name}.gltf"
    with_camera(source, scene_file, lo, hi, name in FROM_BEHIND)

    scene = new_empty_scene()
    bpy.ops.import_scene.gltf(filepath=str(scene_file))
    scene.camera = next(o for o in scene.objects if o.type == "CAMERA" and o.name.startswith("TestCamera"))
    plain_world(scene, WORLD)
    scene.render.resolution_x = scene.render.resolution_y = SIZE
    scene.view_settings.view_transform = "Standard"
    fair_cycles(scene, SAMPLES, BOUNCES)
    cycles = []
    for seed in range(1, SEEDS + 1):
        scene.cycles.seed = seed
        cycles.append(render_rgb(tmp_path / f"c{seed}.exr"))
    glint = glint_seeds(executable, scene_file, tmp_path, SEEDS)

    z, bias = tile_agreement(cycles, glint, TILE)
    print(f"{name}: bias against Cycles {np.round(bias * 100, 2)} %, worst tile {z.max():.1f} σ")
    assert z.max() < 5.0, (name, z.max(), bias)
