"""The Glint render engine inside Blender: F12 through bpy.ops.render.render."""

import json
import math
import os
import subprocess
import time

import bpy
import numpy as np
import pytest

import glint
from glint import daemon, export
from helpers import add_camera, give_principled, plain_world, read_exr

WIDTH, HEIGHT = 48, 36


def build_scene(scene):
    """A grey floor, a red emissive-free sphere, a yellow emitting cube, an
    area light, a plain-colour World and a camera: everything Glint reads."""
    bpy.ops.mesh.primitive_plane_add(size=20)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=1, location=(0, 0, 1))
    give_principled(bpy.context.object, "Red", Base_Color=(0.8, 0.1, 0.1, 1), Roughness=0.4)
    bpy.ops.mesh.primitive_cube_add(size=0.5, location=(2, 1, 0.25))
    give_principled(bpy.context.object, "Glow", Emission_Color=(1, 0.8, 0.2, 1), Emission_Strength=5.0)
    light = bpy.data.lights.new("Panel", "AREA")
    light.shape = "RECTANGLE"
    light.size, light.size_y = 2.0, 1.0
    light.energy = 300.0
    light.color = (1.0, 0.9, 0.8)
    lamp = bpy.data.objects.new("Panel", light)
    lamp.location = (0, 0, 4)
    scene.collection.objects.link(lamp)
    plain_world(scene, (0.2, 0.3, 0.5), 0.5)
    cam = add_camera(scene, (0, -7, 3), (math.radians(72), 0, 0))
    scene.render.resolution_x, scene.render.resolution_y = WIDTH, HEIGHT
    scene.glint.samples = 8
    scene.glint.max_bounces = 4
    return cam


def glb_json(path):
    """The JSON chunk of a GLB file."""
    with open(path, "rb") as f:
        data = f.read()
    length = int.from_bytes(data[12:16], "little")
    return json.loads(data[20 : 20 + length])


def render_to(path):
    bpy.ops.render.render()
    bpy.data.images["Render Result"].save_render(str(path))
    return read_exr(path)


def test_f12_gives_what_glint_render_gives_for_the_exported_scene(empty_scene, executable, tmp_path):
    build_scene(empty_scene)
    objects, images = len(bpy.data.objects), {i.name for i in bpy.data.images}
    result = render_to(tmp_path / "f12.exr")
    d = daemon.current()
    request = json.loads(open(d.path("request.json")).read())
    assert request["width"] == WIDTH and request["height"] == HEIGHT and request["camera"] == "Camera"
    assert request["max_depth"] == 5 and request["samples"] == 8
    cli = tmp_path / "cli.exr"
    subprocess.run(
        [executable, "render", d.path("scene.glb"), "--request", d.path("request.json"), "-o", str(cli)], check=True, capture_output=True
    )
    expected = read_exr(cli)
    assert result.shape == expected.shape == (HEIGHT, WIDTH, 4)
    # Same seed, same per-pixel samples: only the order in which the passes
    # of the progressive render were summed differs (float rounding).
    assert np.allclose(result[..., :3], expected[..., :3], rtol=1e-5, atol=1e-6), np.abs(result - expected).max()
    # The image has light in it: floor, sphere, the glowing cube, the World.
    assert result[..., :3].mean() > 0.05
    # The user's file is untouched: nothing added, no image left behind.
    assert len(bpy.data.objects) == objects
    assert {i.name for i in bpy.data.images} - images <= {"Render Result"}


def test_the_request_carries_area_lights_and_the_world(empty_scene):
    build_scene(empty_scene)
    # An image texture goes through glTF; a procedural one cannot, and
    # reaches the user as a warning.
    red = bpy.data.materials["Red"]
    texture = red.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = bpy.data.images.new("Checker", 8, 8)
    texture.image.generated_type = "UV_GRID"
    red.node_tree.links.new(texture.outputs["Color"], red.node_tree.nodes["Principled BSDF"].inputs["Base Color"])
    noise = red.node_tree.nodes.new("ShaderNodeTexNoise")
    red.node_tree.links.new(noise.outputs["Fac"], red.node_tree.nodes["Principled BSDF"].inputs["Roughness"])
    # An animation and a vertex colour layer no material uses: data Glint
    # does not render.
    sphere = bpy.data.objects["Sphere"]
    sphere.keyframe_insert("location", frame=1)
    sphere.location.z += 1
    sphere.keyframe_insert("location", frame=10)
    sphere.data.color_attributes.new("Col", "FLOAT_COLOR", "POINT")
    _, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
    assert any(w.startswith("Red: procedural textures cannot go through glTF") for w in warnings), warnings
    assert not any(w.startswith("Panel:") for w in warnings), warnings
    # Light settings Glint does not render are named, one warning a light;
    # a Spread and Cast Shadow, which it renders, go in the request.
    bpy.data.lights["Panel"].spread = math.radians(60)
    bpy.data.lights["Panel"].use_shadow = False
    bpy.data.objects["Panel"].visible_glossy = False
    request, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
    assert "Panel: hidden from glossy rays not rendered by Glint (it lights as with Blender's defaults)" in warnings, warnings
    assert request["area_lights"][0]["spread"] == pytest.approx(math.radians(60))
    assert request["area_lights"][0]["cast_shadow"] is False
    bpy.data.lights["Panel"].spread, bpy.data.lights["Panel"].use_shadow = math.pi, True
    bpy.data.objects["Panel"].visible_glossy = True
    bpy.ops.render.render()
    # The exported file holds what Glint renders: the image and the UVs of
    # the textured mesh, no tangents (no normal map), colours, animations
    # or skins.
    doc = glb_json(daemon.current().path("scene.glb"))
    attributes = {a for mesh in doc["meshes"] for p in mesh["primitives"] for a in p["attributes"]}
    assert attributes == {"POSITION", "NORMAL", "TEXCOORD_0"}, attributes
    assert len(doc["images"]) == 1 and any(m.get("pbrMetallicRoughness", {}).get("baseColorTexture") for m in doc["materials"])
    assert not any(doc.get(k) for k in ("animations", "skins")), sorted(doc)
    request = json.loads(open(daemon.current().path("request.json")).read())
    assert request["background"] == pytest.approx([0.1, 0.15, 0.25])
    (panel,) = request["area_lights"]
    assert panel["shape"] == "RECTANGLE" and panel["size"] == [2.0, 1.0] and panel["power"] == 300.0 and panel["portal"] is False
    m = np.array(panel["matrix"]).reshape(4, 4).T  # column-major
    # Blender (0, 0, 4), Z up → glTF (0, 4, 0), Y up; an unrotated light
    # shines down its −Z: glTF −Y.
    assert m[:3, 3] == pytest.approx([0, 4, 0])
    assert -m[:3, 2] == pytest.approx([0, -1, 0])


def test_a_tangent_node_goes_in_the_request(empty_scene):
    """Anisotropic renders along Cycles' default tangent unless a Tangent
    node feeds the Tangent input: its Radial axis or its UV map goes in the
    request; anything else feeding it is named in a warning."""
    build_scene(empty_scene)
    red = bpy.data.materials["Red"]
    principled = red.node_tree.nodes["Principled BSDF"]
    principled.inputs["Anisotropic"].default_value = 0.5

    def tangents():
        request, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
        return request["anisotropy_tangents"], [w for w in warnings if "Tangent" in w]

    assert tangents() == ([], [])
    tangent = red.node_tree.nodes.new("ShaderNodeTangent")
    red.node_tree.links.new(tangent.outputs["Tangent"], principled.inputs["Tangent"])
    tangent.direction_type, tangent.axis = "RADIAL", "X"
    assert tangents() == ([{"material": "Red", "radial_axis": "X"}], [])
    tangent.direction_type, tangent.uv_map = "UV_MAP", "UVMap"
    assert tangents() == ([{"material": "Red", "uv_map": 0}], [])
    geometry = red.node_tree.nodes.new("ShaderNodeNewGeometry")
    red.node_tree.links.new(geometry.outputs["Tangent"], principled.inputs["Tangent"])
    records, warnings = tangents()
    assert records == [] and warnings and warnings[0].startswith("Red: a Tangent other than a Tangent node's"), warnings
    principled.inputs["Anisotropic"].default_value = 0.0
    assert tangents() == ([], [])


def test_a_volume_absorption_goes_in_the_request_or_is_named(empty_scene):
    """A Volume Absorption on the Material Output's Volume goes in the
    request (Color clamped to [0, 1], Density to ≥ 0; its render:
    test_glass_vs_cycles.py); any other volume, and the World's, is named
    in a warning."""
    build_scene(empty_scene)
    red = bpy.data.materials["Red"]
    red.node_tree.nodes["Principled BSDF"].inputs["Transmission Weight"].default_value = 1.0
    output = next(n for n in red.node_tree.nodes if n.type == "OUTPUT_MATERIAL")

    def volumes():
        request, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
        return request.get("volume_absorption"), [w for w in warnings if "volume" in w.lower()]

    assert volumes() == (None, [])
    # The World's fog is named too.
    world = empty_scene.world.node_tree
    fog = world.nodes.new("ShaderNodeVolumePrincipled")
    world.links.new(fog.outputs["Volume"], next(n for n in world.nodes if n.type == "OUTPUT_WORLD").inputs["Volume"])
    assert volumes()[1] == ["the World's Volume (fog, haze) is not rendered by Glint: its rays cross empty space"]
    world.nodes.remove(fog)
    absorption = red.node_tree.nodes.new("ShaderNodeVolumeAbsorption")
    absorption.inputs["Color"].default_value = (0.5, 1.5, 0.25, 1.0)
    absorption.inputs["Density"].default_value = 3.0
    red.node_tree.links.new(absorption.outputs["Volume"], output.inputs["Volume"])
    assert volumes() == ([{"material": "Red", "color": [0.5, 1.0, 0.25], "density": 3.0}], [])
    absorption.inputs["Density"].default_value = -2.0
    assert volumes()[0][0]["density"] == 0.0
    value = red.node_tree.nodes.new("ShaderNodeValue")
    red.node_tree.links.new(value.outputs["Value"], absorption.inputs["Density"])
    records, warnings = volumes()
    assert records is None and warnings and warnings[0].startswith("Red: a volume other than a Volume Absorption"), warnings
    scatter = red.node_tree.nodes.new("ShaderNodeVolumePrincipled")
    red.node_tree.links.new(scatter.outputs["Volume"], output.inputs["Volume"])
    records, warnings = volumes()
    assert records is None and warnings and warnings[0].startswith("Red: "), warnings


def test_surfaces_without_a_principled_bsdf_go_in_the_request_or_are_named(empty_scene):
    """A Diffuse, Glossy, Glass or Translucent BSDF straight into the output goes in the
    request (their renders: test_materials_vs_cycles.py,
    test_glass_vs_cycles.py), with a warning where Glint renders it only
    approximately, and so does a Translucent BSDF; a surface glTF cannot
    carry otherwise (a Subsurface Scattering node) is named in a warning; a Mix Shader of a Principled BSDF and such
    a node goes in the request with the node's share (its render:
    test_materials_vs_cycles.py), any other mix of a Principled BSDF is
    named in a warning (Glint renders the Principled BSDF alone, as the
    exporter writes it), and an Emission shader goes through glTF."""
    build_scene(empty_scene)
    red = bpy.data.materials["Red"]
    nodes, links = red.node_tree.nodes, red.node_tree.links
    output = next(n for n in nodes if n.type == "OUTPUT_MATERIAL")
    principled = nodes["Principled BSDF"]

    def surfaces(node=None):
        if node is not None:
            links.new(node.outputs[0], output.inputs["Surface"])
        request, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
        named = [w for w in warnings if "BSDF" in w]
        return request.get("bsdf_nodes"), [w.split(":")[1].split(" (")[0].strip() for w in named], request.get("single_scatter_materials")

    assert surfaces() == (None, [], None)
    diffuse = nodes.new("ShaderNodeBsdfDiffuse")
    diffuse.inputs["Color"].default_value = (0.5, 1.5, 0.25, 1.0)
    assert surfaces(diffuse) == ([{"material": "Red", "node": "diffuse", "color": [0.5, 1.0, 0.25], "roughness": 0.0}], [], None)
    # A rough Diffuse BSDF is Cycles' Oren–Nayar, which Glint renders.
    diffuse.inputs["Roughness"].default_value = 0.5
    assert surfaces() == ([{"material": "Red", "node": "diffuse", "color": [0.5, 1.0, 0.25], "roughness": 0.5}], [], None)
    diffuse.inputs["Normal"].default_value = (0.0, 0.0, 1.0)
    links.new(nodes.new("ShaderNodeNormal").outputs["Normal"], diffuse.inputs["Normal"])
    assert surfaces()[1] == ["Glint renders this BSDF node as the nearest Principled BSDF"]
    glossy = nodes.new("ShaderNodeBsdfGlossy")
    glossy.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    glossy.inputs["Roughness"].default_value = 0.25
    assert surfaces(glossy) == ([{"material": "Red", "node": "glossy", "color": [1.0, 1.0, 1.0], "roughness": 0.25}], [], None)
    glossy.distribution = "GGX"
    assert surfaces()[2] == ["Red"]
    glossy.inputs["Color"].default_value = (0.9, 0.5, 0.2, 1.0)
    assert surfaces()[1] == ["Glint renders this BSDF node as the nearest Principled BSDF"]
    glass = nodes.new("ShaderNodeBsdfGlass")
    glass.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    glass.inputs["IOR"].default_value = 1.33
    records, named, _ = surfaces(glass)
    assert records == [{"material": "Red", "node": "glass", "color": [1.0, 1.0, 1.0], "roughness": 0.0, "ior": pytest.approx(1.33)}] and named == [], (records, named)
    glass.inputs["IOR"].default_value = 0.8
    records, named, _ = surfaces()
    assert records[0]["ior"] == 1.0 and named == ["Glint renders this BSDF node as the nearest Principled BSDF"], (records, named)
    translucent = nodes.new("ShaderNodeBsdfTranslucent")
    translucent.inputs["Color"].default_value = (0.25, 0.75, 0.125, 1.0)
    assert surfaces(translucent) == ([{"material": "Red", "node": "translucent", "color": [0.25, 0.75, 0.125]}], [], None)
    subsurface = nodes.new("ShaderNodeSubsurfaceScattering")
    records, named, _ = surfaces(subsurface)
    assert records is None and len(named) == 1 and named[0].startswith("a surface without a Principled BSDF"), named
    mix = nodes.new("ShaderNodeMixShader")
    links.new(principled.outputs["BSDF"], mix.inputs[1])
    links.new(subsurface.outputs[0], mix.inputs[2])
    records, named, _ = surfaces(mix)
    assert records is None and len(named) == 1 and named[0].startswith("a Principled BSDF mixed or added with other shaders otherwise"), named
    links.new(translucent.outputs["BSDF"], mix.inputs[2])
    request, _ = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
    assert request["shader_mixes"] == [{"weight": 0.5, "mixed": {"material": "Red", "node": "translucent", "color": [0.25, 0.75, 0.125]}}], request["shader_mixes"]

    def mixes():
        request, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
        return request.get("shader_mixes"), [w for w in warnings if w.startswith("Red:")]

    mix.inputs["Fac"].default_value = 0.25
    links.new(glossy.outputs["BSDF"], mix.inputs[2])
    glossy.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    glossy.distribution = "MULTI_GGX"
    assert mixes() == ([{"weight": 0.25, "mixed": {"material": "Red", "node": "glossy", "color": [1.0, 1.0, 1.0], "roughness": 0.25}}], [])
    # The node above the Principled BSDF takes 1 − Fac.
    links.new(glossy.outputs["BSDF"], mix.inputs[1])
    links.new(principled.outputs["BSDF"], mix.inputs[2])
    assert mixes()[0][0]["weight"] == 0.75
    transparent = nodes.new("ShaderNodeBsdfTransparent")
    links.new(transparent.outputs["BSDF"], mix.inputs[1])
    assert mixes() == ([{"weight": 0.75, "mixed": {"material": "Red", "node": "transparent", "color": [1.0, 1.0, 1.0]}}], [])
    # An Emission shader: the exporter writes its emission as the
    # material's, so the whole (each half's × its share) goes in.
    emission = nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (1.0, 0.5, 0.0, 1.0)
    emission.inputs["Strength"].default_value = 4.0
    principled.inputs["Emission Color"].default_value = (0.0, 0.0, 1.0, 1.0)
    principled.inputs["Emission Strength"].default_value = 2.0
    links.new(emission.outputs["Emission"], mix.inputs[1])
    record = mixes()[0][0]
    assert record["weight"] == 0.75 and record["mixed"] == {"material": "Red", "node": "emission", "color": [1.0, 0.5, 0.0], "strength": 4.0}, record
    assert record["emission"] == pytest.approx([3.0, 1.5, 0.5]), record
    # An Add Shader keeps both whole: no share of the BSDF is black.
    add = nodes.new("ShaderNodeAddShader")
    links.new(principled.outputs["BSDF"], add.inputs[0])
    links.new(emission.outputs["Emission"], add.inputs[1])
    links.new(add.outputs["Shader"], output.inputs["Surface"])
    record = mixes()[0][0]
    assert record["weight"] == 0.0 and record["emission"] == pytest.approx([4.0, 2.0, 2.0]), record
    links.new(glossy.outputs["BSDF"], add.inputs[1])
    assert mixes()[0] is None and "otherwise than in one Mix Shader" in mixes()[1][0], mixes()
    links.new(mix.outputs["Shader"], output.inputs["Surface"])
    principled.inputs["Emission Strength"].default_value = 0.0
    glossy.distribution = "GGX"
    links.new(glossy.outputs["BSDF"], mix.inputs[1])
    assert len(mixes()[1]) == 1 and "nearest Principled BSDF" in mixes()[1][0], mixes()
    value = nodes.new("ShaderNodeValue")
    links.new(value.outputs["Value"], mix.inputs["Fac"])
    assert mixes()[0] is None and "otherwise than in one Mix Shader" in mixes()[1][0], mixes()
    assert surfaces(nodes.new("ShaderNodeEmission")) == (None, [], None)


def test_principled_inputs_glint_leaves_out_are_named(empty_scene):
    """Subsurface, Sheen and Thin Film, which Glint does not render, are
    named in one warning per material once used (above 0 or linked), and
    not before; Diffuse Roughness goes in the request, clamped to 1, and
    only a linked one is warned of."""
    build_scene(empty_scene)
    principled = bpy.data.materials["Red"].node_tree.nodes["Principled BSDF"]

    def named():
        _, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
        return [w for w in warnings if "of the Principled BSDF" in w]

    assert named() == []
    principled.inputs["Sheen Weight"].default_value = 0.5
    principled.inputs["Subsurface Weight"].default_value = 0.2
    assert named() == ["Red: Subsurface, Sheen of the Principled BSDF not rendered by Glint (rendered as 0)"]
    principled.inputs["Sheen Weight"].default_value = 0.0
    principled.inputs["Diffuse Roughness"].default_value = 0.6
    assert named() == ["Red: Subsurface of the Principled BSDF not rendered by Glint (rendered as 0)"]
    request, _ = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
    assert request["diffuse_roughness"] == [{"material": "Red", "roughness": pytest.approx(0.6)}], request
    value = bpy.data.materials["Red"].node_tree.nodes.new("ShaderNodeValue")
    bpy.data.materials["Red"].node_tree.links.new(value.outputs["Value"], principled.inputs["Diffuse Roughness"])
    request, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
    assert "diffuse_roughness" not in request and ["Red: a linked Diffuse Roughness of the Principled BSDF is not rendered by Glint (rendered as 0)"] == [w for w in warnings if "Diffuse Roughness" in w], warnings


def test_ray_visibility_goes_in_the_request(empty_scene):
    """Objects hidden from the camera, and those hidden from other rays
    with the kinds, are listed in the request (their render:
    test_visibility_vs_cycles.py) with no warning; Volume Scatter, which
    Glint traces no rays of, is left out."""
    build_scene(empty_scene)
    request, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
    assert request["hidden_from_camera"] == [] and request["hidden_from_rays"] == [], request
    sphere = bpy.data.objects["Sphere"]
    sphere.visible_camera = False
    sphere.visible_shadow = False
    sphere.visible_glossy = False
    sphere.visible_volume_scatter = False
    request, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
    assert request["hidden_from_camera"] == ["Sphere"], request["hidden_from_camera"]
    assert request["hidden_from_rays"] == [{"object": "Sphere", "rays": ["shadow", "glossy"]}], request["hidden_from_rays"]
    assert not any("Sphere" in w for w in warnings), warnings


def test_the_light_paths_setting_goes_in_the_request(empty_scene):
    """Auto leaves the choice to Glint (no field: the renderer decides from
    the scene); On and Off say so, and `glint render` honours the field
    (tests/cli.rs)."""
    build_scene(empty_scene)
    seen = {}
    for setting in ("AUTO", "ON", "OFF"):
        empty_scene.glint.light_paths = setting
        request, _ = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
        seen[setting] = request.get("light_paths")
    assert seen == {"AUTO": None, "ON": True, "OFF": False}, seen


def test_the_noise_threshold_goes_in_the_request(empty_scene):
    """Adaptive sampling off (the default) leaves the fields out; on, the
    threshold and Min Samples go in the request, which `glint render`
    honours (tests/cli.rs)."""
    build_scene(empty_scene)
    settings = empty_scene.glint
    request, _ = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
    assert "noise_threshold" not in request and "adaptive_min_samples" not in request
    settings.use_adaptive_sampling, settings.adaptive_threshold, settings.adaptive_min_samples = True, 0.05, 24
    request, _ = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
    assert request["noise_threshold"] == pytest.approx(0.05) and request["adaptive_min_samples"] == 24


def test_an_adaptive_render_ends_with_a_full_progress_bar(empty_scene, monkeypatch):
    """Adaptive sampling stops below the sample budget; the render is
    done all the same, and Blender's progress bar ends full (it had ended
    where samples / budget left it)."""
    build_scene(empty_scene)
    settings = empty_scene.glint
    settings.samples, settings.use_adaptive_sampling, settings.adaptive_threshold, settings.adaptive_min_samples = 4096, True, 0.2, 8
    shown = []
    monkeypatch.setattr(glint.engine.GlintRenderEngine, "_show_progress", lambda self, fraction: shown.append(fraction))
    bpy.ops.render.render()
    status = daemon.current().status()
    print(f"adaptive: {status['samples']} of {status['total_samples']} samples, progress shown {shown[-3:]}")
    assert status["state"] == "done" and status["samples"] < status["total_samples"], status
    assert shown and shown[-1] == 1.0, shown


def test_cancel_stops_the_render_promptly_and_leaves_nothing_behind(empty_scene, monkeypatch):
    build_scene(empty_scene)
    empty_scene.glint.samples = 1_000_000
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 128, 96
    start = time.monotonic()
    # Esc sets the flag test_break reads, which cannot be set from Python;
    # here the engine's one caller of test_break says "cancel" after 1 s.
    monkeypatch.setattr(glint.engine.GlintRenderEngine, "_cancel_requested", lambda self: time.monotonic() - start > 1.0)
    bpy.ops.render.render()
    took = time.monotonic() - start
    d = daemon.current()
    status = d.status()
    print(f"cancelled after 1 s: render() returned after {took:.2f} s")
    assert took < 1.0 + 2.0, took
    assert status["state"] == "cancelled"
    time.sleep(0.3)
    assert d.status()["sequence"] == status["sequence"], "the daemon must not go on rendering"
    assert not [n for n in os.listdir(d.job_dir) if n.endswith(".tmp") or n == "cancel"]
    # Ending the session (unregistering) ends the daemon and its folder.
    process, folder = d.process, d.job_dir
    daemon.stop()
    assert process.poll() is not None and not os.path.exists(folder)


def test_a_missing_executable_is_one_clear_error(empty_scene, monkeypatch):
    build_scene(empty_scene)
    monkeypatch.setenv("GLINT_EXECUTABLE", "/nonexistent/glint")
    with pytest.raises(RuntimeError) as error:
        bpy.ops.render.render()
    message = str(error.value)
    assert "/nonexistent/glint" in message and "GLINT_EXECUTABLE" in message and "Traceback" not in message


def test_a_panoramic_camera_renders_and_stays_panoramic(empty_scene, tmp_path):
    """Blender's glTF exporter raises a bare KeyError on a panoramic camera:
    the add-on exports it (and any other panoramic camera of the scene)
    as a perspective one for the exporter's sake and turns it back, and
    the request carries its panorama: Cycles' settings, with a fisheye's
    sensor fitted to the image as Cycles fits it (Auto: the larger side)."""
    cam = build_scene(empty_scene)
    cam.data.type, cam.data.panorama_type, cam.data.fisheye_lens = "PANO", "FISHEYE_EQUISOLID", 8.0
    other = bpy.data.objects.new("Other", bpy.data.cameras.new("Other"))
    other.data.type = "PANO"
    empty_scene.collection.objects.link(other)
    empty_scene.render.resolution_x, empty_scene.render.resolution_y = 30, 60
    empty_scene.glint.samples = 2
    result = render_to(tmp_path / "pano.exr")
    assert result.shape == (60, 30, 4) and np.isfinite(result).all() and result[..., :3].max() > 0
    assert (cam.data.type, other.data.type) == ("PANO", "PANO")
    request, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "job", 30, 60)
    panorama = request["lens"]["panorama"]
    assert panorama["type"] == "FISHEYE_EQUISOLID" and panorama["lens"] == 8.0 and panorama["sensor"] == [18.0, 36.0], panorama
    cam.data.dof.use_dof, cam.data.dof.focus_distance = True, 3.0
    request, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "job", 30, 60)
    assert request["lens"]["aperture"]["focus_distance"] == 3.0 and "panorama" in request["lens"] and not warnings, (request["lens"], warnings)


def test_an_animation_renders_every_frame_with_its_camera(empty_scene, tmp_path):
    cam = build_scene(empty_scene)
    empty_scene.glint.samples = 2
    cam.location.x = -2
    cam.keyframe_insert("location", frame=1)
    cam.location.x = 2
    cam.keyframe_insert("location", frame=2)
    empty_scene.frame_start, empty_scene.frame_end = 1, 2
    empty_scene.render.filepath = str(tmp_path / "frame_")
    bpy.ops.render.render(animation=True)
    frames = [read_exr(tmp_path / f"frame_000{n}.exr") for n in (1, 2)]
    # The camera moves right, so the scene moves left in the image: the
    # brightness-weighted centre of the picture shifts left.
    def centre(img):
        lum = img[..., :3].sum(axis=2)
        return (lum.sum(axis=0) * np.arange(img.shape[1])).sum() / lum.sum()
    assert centre(frames[1]) < centre(frames[0]) - 1.0, (centre(frames[0]), centre(frames[1]))


def test_the_pixel_filter_goes_in_the_request(empty_scene):
    """Film › Pixel Filter is Cycles' setting, which the .blend keeps: the
    request carries it (its render: test_camera_vs_cycles.py), Blender's
    default Blackman-Harris of 1.5 px included, and a box of one pixel
    whatever its Width, as Cycles renders one."""
    build_scene(empty_scene)

    def sent():
        request, _ = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
        return request["pixel_filter"]

    assert sent() == {"type": "blackman_harris", "width": pytest.approx(1.5)}
    empty_scene.cycles.pixel_filter_type, empty_scene.cycles.filter_width = "GAUSSIAN", 2.0
    assert sent() == {"type": "gaussian", "width": pytest.approx(2.0)}
    empty_scene.cycles.pixel_filter_type, empty_scene.cycles.filter_width = "BOX", 3.0
    assert sent() == {"type": "box", "width": 1.0}


def test_two_plain_nodes_mixed_go_in_the_request(empty_scene):
    """A Mix Shader of two plain nodes, no Principled BSDF: the upper goes
    in as the material (`bsdf_nodes`), the lower mixed in by Fac
    (`shader_mixes`; its render: test_materials_vs_cycles.py). Plain GGX
    asked by a Glossy half is the material's; two glossy halves asking
    for different ones are named as approximate; an Emission half is named
    as not rendered."""
    build_scene(empty_scene)
    red = bpy.data.materials["Red"]
    nodes, links = red.node_tree.nodes, red.node_tree.links
    output = next(n for n in nodes if n.type == "OUTPUT_MATERIAL")
    diffuse, glossy, mix = nodes.new("ShaderNodeBsdfDiffuse"), nodes.new("ShaderNodeBsdfGlossy"), nodes.new("ShaderNodeMixShader")
    diffuse.inputs["Color"].default_value = (0.5, 0.25, 0.125, 1.0)
    glossy.inputs["Color"].default_value = (1.0, 1.0, 1.0, 1.0)
    glossy.inputs["Roughness"].default_value = 0.25
    mix.inputs["Fac"].default_value = 0.25
    links.new(diffuse.outputs["BSDF"], mix.inputs[1])
    links.new(glossy.outputs["BSDF"], mix.inputs[2])
    links.new(mix.outputs["Shader"], output.inputs["Surface"])

    def request():
        r, warnings = export.render_request(bpy.context.evaluated_depsgraph_get(), "j", WIDTH, HEIGHT)
        return r.get("bsdf_nodes"), r.get("shader_mixes"), r.get("single_scatter_materials"), [w.split(":")[1].strip()[:30] for w in warnings if w.startswith("Red:")]

    assert request() == (
        [{"material": "Red", "node": "diffuse", "color": [0.5, 0.25, 0.125], "roughness": 0.0}],
        [{"weight": 0.25, "mixed": {"material": "Red", "node": "glossy", "color": [1.0, 1.0, 1.0], "roughness": 0.25}}],
        None,
        [],
    ), request()
    glossy.distribution = "GGX"
    assert request()[2:] == (["Red"], [])
    glass = nodes.new("ShaderNodeBsdfGlass")
    glass.distribution = "MULTI_GGX"
    links.new(glass.outputs["BSDF"], mix.inputs[1])
    assert request()[2:] == (["Red"], ["Glint renders this BSDF node a"]), request()
    emission = nodes.new("ShaderNodeEmission")
    links.new(emission.outputs["Emission"], mix.inputs[1])
    assert request() == (None, None, None, ["a surface without a Principled"]), request()
