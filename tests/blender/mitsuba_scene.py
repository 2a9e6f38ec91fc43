"""The Blender scene, as Cycles renders it, converted for Mitsuba 3, for the
three-way benchmark (convergence.py --mitsuba).

What carries over, and how it differs from Cycles' reading:
- meshes, world-space triangles with their smooth or flat normals;
- the camera (field of view, square image), a one-pixel box filter;
- each Principled BSDF as the closest fast Mitsuba model, two-sided:
  metallic ≥ 0.5 → `roughconductor` (GGX, α = roughness², reflectance =
  base colour with Fresnel 1: Cycles' Schlick-like F82 rises to white at
  grazing angles, this does not); Specular IOR Level 0 → `diffuse`;
  Transmission Weight ≥ 0.5 → `dielectric` (smooth) or `roughdielectric`
  (GGX) of its IOR, its transmittance √base colour at each crossing (as
  Cycles tints); otherwise Mitsuba's `principled` (Disney's: its diffuse
  has a retro-reflection term Cycles 4 dropped; `roughplastic`, the
  faster model, was 46% darker on the Cornell box, its coat's internal
  reflections and 1/η² taking what Cycles' energy-conserving layer
  keeps);
- Emission Color × Strength → an `area` emitter of that radiance on both
  faces (as Cycles' emission), Blender area lights of square/rectangle shape → a
  `rectangle` emitter of radiance colour·power/(π·A), a plain World colour
  → `constant`; a point light of power P and radius r → a `sphere` of
  radiance colour·P/(4π·πr²), the same intensity P/(4π) (Cycles with Soft
  Falloff, Blender's default, draws a disk of that radius facing the
  point it lights: the light at distance d differs by about r²/d²), one
  of radius 0 → a `point` of that intensity; Cycles' portals (area lights marked Portal) are left out:
  Mitsuba 3 has none, and they give no light of their own.
- lights hidden from the camera (Blender's default): the path integrator's
  `hide_emitters`, which hides every emitter, so only where area lights
  are the only emitters (the lamp hall; 2.2× too bright without, its
  lamps in view);
- `path` integrator, Cycles' Max Bounces B as max_depth B + 2 (Mitsuba
  counts the emitter seen as a depth), Russian roulette from depth 5
  (Mitsuba's default).
"""

import math

import bpy
import mitsuba as mi
import numpy as np


def principled_inputs(material):
    """Base colour, metallic, roughness, specular level, emission of a
    material's Principled BSDF (unlinked inputs; defaults without one)."""
    bsdf = next((n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None) if material and material.use_nodes else None
    if bsdf is None:
        return (0.8, 0.8, 0.8), 0.0, 0.5, 0.5, (0.0, 0.0, 0.0)
    i = bsdf.inputs
    emission = np.array(i["Emission Color"].default_value[:3]) * i["Emission Strength"].default_value
    return tuple(i["Base Color"].default_value[:3]), i["Metallic"].default_value, i["Roughness"].default_value, i["Specular IOR Level"].default_value, tuple(emission)


def glass_inputs(material):
    """Transmission Weight and IOR of a material's Principled BSDF."""
    bsdf = next((n for n in material.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None) if material and material.use_nodes else None
    if bsdf is None:
        return 0.0, 1.5
    return bsdf.inputs["Transmission Weight"].default_value, bsdf.inputs["IOR"].default_value


def bsdf_dict(inputs, glass=(0.0, 1.5)):
    """The BSDF for a material's `principled_inputs` and `glass_inputs`:
    Cycles shades both faces of a surface; Mitsuba's models, one (its
    dielectrics, both)."""
    (transmission, ior), (base, _, roughness) = glass, inputs[:3]
    if transmission >= 0.5:
        tint = {"type": "rgb", "value": [math.sqrt(c) for c in base]}
        if roughness * roughness < 1e-3:
            return {"type": "dielectric", "int_ior": ior, "ext_ior": 1.0, "specular_transmittance": tint}
        return {"type": "roughdielectric", "distribution": "ggx", "alpha": roughness * roughness, "int_ior": ior, "ext_ior": 1.0, "specular_transmittance": tint}
    return {"type": "twosided", "bsdf": one_sided_bsdf(*inputs[:4])}


def one_sided_bsdf(base, metallic, roughness, specular):
    rgb = {"type": "rgb", "value": list(base)}
    alpha = max(roughness * roughness, 1e-3)
    if metallic >= 0.5:
        return {"type": "roughconductor", "material": "none", "distribution": "ggx", "alpha": alpha, "specular_reflectance": rgb}
    if specular == 0.0:
        return {"type": "diffuse", "reflectance": rgb}
    return {"type": "principled", "base_color": rgb, "roughness": roughness, "metallic": 0.0, "specular": specular}


def mesh_shapes(depsgraph):
    """One Mitsuba mesh per (object, material slot), in world space, with
    its BSDF and emitter."""
    shapes = []
    for instance in depsgraph.object_instances:
        obj = instance.object
        if obj.type != "MESH":
            continue
        mesh = obj.evaluated_get(depsgraph).to_mesh()
        mesh.calc_loop_triangles()
        m = np.array(instance.matrix_world)
        normal_m = np.array(instance.matrix_world.to_3x3().inverted().transposed())
        tris = mesh.loop_triangles
        n = len(tris)
        loops = np.empty(n * 3, dtype=np.int64)
        tris.foreach_get("loops", loops)
        slots = np.empty(n, dtype=np.int64)
        tris.foreach_get("material_index", slots)
        verts = np.empty(len(mesh.vertices) * 3)
        mesh.vertices.foreach_get("co", verts)
        loop_vert = np.empty(len(mesh.loops), dtype=np.int64)
        mesh.loops.foreach_get("vertex_index", loop_vert)
        normals = np.empty(len(mesh.corner_normals) * 3)
        mesh.corner_normals.foreach_get("vector", normals)
        p = verts.reshape(-1, 3)[loop_vert[loops]] @ m[:3, :3].T + m[:3, 3]
        nn = normals.reshape(-1, 3)[loops] @ normal_m.T
        nn /= np.maximum(np.linalg.norm(nn, axis=1, keepdims=True), 1e-12)
        for slot in np.unique(slots):
            pick = np.repeat(slots == slot, 3)
            material = obj.material_slots[slot].material if slot < len(obj.material_slots) else None
            inputs = principled_inputs(material)
            emission = inputs[4]
            emitter = {"type": "area", "radiance": {"type": "rgb", "value": list(emission)}} if max(emission) > 0 else None
            shapes.append(mitsuba_mesh(f"{obj.name}-{slot}", p[pick], nn[pick], bsdf_dict(inputs, glass_inputs(material)), emitter))
            if emitter:
                # Cycles' emission lights both faces (the add-on tells Glint
                # so); Mitsuba's area emitter, the front: a reversed copy
                # that only emits (a null BSDF lets rays through) lights the
                # back. It sits 10 µm behind the surface: coincident, a ray
                # passing it would skip the surface too.
                tri = p[pick].reshape(-1, 3, 3)[:, ::-1]
                face = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
                face /= np.maximum(np.linalg.norm(face, axis=1, keepdims=True), 1e-30)
                back = (tri + 1e-5 * face[:, None, :]).reshape(-1, 3)
                back_n = -nn[pick].reshape(-1, 3, 3)[:, ::-1].reshape(-1, 3)
                shapes.append(mitsuba_mesh(f"{obj.name}-{slot}-back", back, back_n, {"type": "null"}, emitter))
        obj.evaluated_get(depsgraph).to_mesh_clear()
    return shapes


def mitsuba_mesh(name, positions, normals, bsdf, emitter):
    """A Mitsuba triangle mesh from per-corner positions and normals."""
    props = mi.Properties()
    props["bsdf"] = mi.load_dict(bsdf)
    if emitter:
        props["emitter"] = mi.load_dict(emitter)
    count = len(positions)
    shape = mi.Mesh(name, count, count // 3, props, has_vertex_normals=True)
    params = mi.traverse(shape)
    params["vertex_positions"] = mi.Float(np.ascontiguousarray(positions, dtype=np.float32).ravel())
    params["vertex_normals"] = mi.Float(np.ascontiguousarray(normals, dtype=np.float32).ravel())
    params["faces"] = mi.UInt32(np.arange(count, dtype=np.uint32))
    params.update()
    return shape


def lights_of_type(depsgraph, kind):
    """(object, world matrix) of each Blender light of type `kind`."""
    for instance in depsgraph.object_instances:
        obj = instance.object
        if obj.type == "LIGHT" and obj.data.type == kind:
            yield obj, np.array(instance.matrix_world)


def emitting_shape(shape, radiance):
    """A Mitsuba shape dict that emits `radiance` and reflects nothing."""
    return {
        **shape,
        "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0.0, 0.0, 0.0]}},
        "emitter": {"type": "area", "radiance": {"type": "rgb", "value": radiance.tolist()}},
    }


def area_lights(depsgraph):
    lights = {}
    for obj, world in lights_of_type(depsgraph, "AREA"):
        light = obj.data
        if getattr(light.cycles, "is_portal", False):
            continue
        if light.shape not in {"SQUARE", "RECTANGLE"}:
            raise ValueError(f"area light {obj.name}: only square and rectangle lights convert")
        sx = light.size
        sy = light.size_y if light.shape == "RECTANGLE" else light.size
        # Mitsuba's rectangle spans [−1, 1]² facing +Z; Blender's emits to −Z.
        local = np.diag([sx / 2, sy / 2, -1.0, 1.0])
        to_world = world @ local
        area = sx * sy * np.linalg.norm(np.cross(world[:3, 0], world[:3, 1]))
        radiance = np.array(light.color[:3]) * light.energy / (math.pi * area)
        lights[obj.name] = emitting_shape({"type": "rectangle", "to_world": mi.ScalarTransform4f(to_world.tolist())}, radiance)
    return lights


def point_lights(depsgraph):
    lights = {}
    for obj, world in lights_of_type(depsgraph, "POINT"):
        light = obj.data
        centre = world[:3, 3]
        intensity = np.array(light.color[:3]) * light.energy / (4 * math.pi)
        r = light.shadow_soft_size
        if r > 0:
            lights[obj.name] = emitting_shape({"type": "sphere", "center": centre.tolist(), "radius": r}, intensity / (math.pi * r * r))
        else:
            lights[obj.name] = {"type": "point", "position": centre.tolist(), "intensity": {"type": "rgb", "value": intensity.tolist()}}
    return lights


def scene_dict(scene, bounces):
    """A Mitsuba scene dict for the Blender scene as Cycles would render it."""
    depsgraph = bpy.context.evaluated_depsgraph_get()
    if next(lights_of_type(depsgraph, "SUN"), None) is not None:
        raise ValueError("the Mitsuba conversion has no sun (Mitsuba's directional emitter has no angle)")
    camera = scene.camera
    # Blender's camera looks down −Z with +X right; Mitsuba's down +Z with +X left.
    to_world = np.array(camera.matrix_world) @ np.diag([-1.0, 1.0, -1.0, 1.0])
    width, height = scene.render.resolution_x, scene.render.resolution_y
    # The axis Blender fits the sensor to, and its angle.
    fit = camera.data.sensor_fit
    if fit == "AUTO":
        fit = "HORIZONTAL" if width >= height else "VERTICAL"
    axis, fov = ("x", camera.data.angle_x) if fit == "HORIZONTAL" else ("y", camera.data.angle_y)
    d = {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": bounces + 2},
        "sensor": {
            "type": "perspective",
            "fov_axis": axis,
            "fov": math.degrees(fov),
            "to_world": mi.ScalarTransform4f(to_world.tolist()),
            "film": {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"}, "pixel_format": "rgb"},
            "sampler": {"type": "independent"},
        },
    }
    for k, shape in enumerate(mesh_shapes(depsgraph)):
        d[f"mesh{k}"] = shape
    d.update(area_lights(depsgraph))
    d.update(point_lights(depsgraph))
    world = scene.world
    if world is not None and world.use_nodes:
        bg = world.node_tree.nodes.get("Background")
        if bg is not None and not bg.inputs["Color"].is_linked:
            colour = np.array(bg.inputs["Color"].default_value[:3]) * bg.inputs["Strength"].default_value
            if colour.max() > 0:
                d["world"] = {"type": "constant", "radiance": {"type": "rgb", "value": colour.tolist()}}
    # Blender's lights are hidden from the camera by default (Object ›
    # Visibility › Camera), Mitsuba's emitters are not; its path integrator
    # can hide them only all at once, so it does where the only emitters
    # are such lights.
    lamps = [i.object for i in depsgraph.object_instances if i.object.type == "LIGHT" and i.object.data.type == "AREA" and not getattr(i.object.data.cycles, "is_portal", False)]
    others = "world" in d or any(d[k].emitter() is not None for k in d if k.startswith("mesh"))
    if lamps and not others and not any(lamp.visible_camera for lamp in lamps):
        d["integrator"]["hide_emitters"] = True
    return d
