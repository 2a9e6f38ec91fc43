#!/usr/bin/env python3
"""Writes cornell-box.gltf, Glint's embedded default scene, and
cornell-box-diffuse.gltf (run from anywhere).

A 2 m Cornell box (glTF units are metres, Y up): white floor, ceiling and back
wall, red left and green right wall, a 0.5 m square ceiling light facing down,
a short white box and a rough gold sphere. Reflectances are the classic
Cornell values in linear Rec.709; the light's radiance is (17, 12, 4)
W·sr⁻¹·m⁻², given as emissiveFactor × KHR_materials_emissive_strength the way
Blender's exporter writes it. Deterministic: the same bytes every run.

The diffuse variant has the same geometry with every material pure Lambert:
KHR_materials_specular specularFactor 0 (what Blender exports for Specular
IOR Level 0) and a white sphere instead of the gold one. It is the scene of
the feature-specialisation benchmark (examples/features.rs).
"""
import base64, json, math, struct, pathlib

quads = []  # (material, [4 corners counter-clockwise seen from the front])

def quad(mat, a, b, c, d):
    quads.append((mat, [a, b, c, d]))

# Walls face into the box.
quad("white", (-1, 0, 1), (1, 0, 1), (1, 0, -1), (-1, 0, -1))          # floor, +Y
quad("white", (-1, 2, -1), (1, 2, -1), (1, 2, 1), (-1, 2, 1))          # ceiling, -Y
quad("white", (-1, 0, -1), (1, 0, -1), (1, 2, -1), (-1, 2, -1))        # back, +Z
quad("red", (-1, 0, 1), (-1, 0, -1), (-1, 2, -1), (-1, 2, 1))          # left, +X
quad("green", (1, 0, -1), (1, 0, 1), (1, 2, 1), (1, 2, -1))            # right, -X
quad("light", (-0.25, 1.99, -0.25), (0.25, 1.99, -0.25), (0.25, 1.99, 0.25), (-0.25, 1.99, 0.25))  # -Y

# Short box: 0.6 m cube rotated -17° about Y.
def box(cx, cz, size, height, angle_deg):
    a = math.radians(angle_deg)
    def p(x, y, z):
        return (cx + x * math.cos(a) + z * math.sin(a), y, cz - x * math.sin(a) + z * math.cos(a))
    s = size / 2
    h = height
    quad("white", p(-s, h, s), p(s, h, s), p(s, h, -s), p(-s, h, -s))   # top
    quad("white", p(-s, 0, s), p(s, 0, s), p(s, h, s), p(-s, h, s))     # +z
    quad("white", p(s, 0, -s), p(-s, 0, -s), p(-s, h, -s), p(s, h, -s))  # -z
    quad("white", p(s, 0, s), p(s, 0, -s), p(s, h, -s), p(s, h, s))     # +x
    quad("white", p(-s, 0, -s), p(-s, 0, s), p(-s, h, s), p(-s, h, -s))  # -x

box(0.42, 0.38, 0.6, 0.6, -17)

materials = {
    "white": {"pbrMetallicRoughness": {"baseColorFactor": [0.725, 0.71, 0.68, 1], "metallicFactor": 0, "roughnessFactor": 1}},
    "red": {"pbrMetallicRoughness": {"baseColorFactor": [0.63, 0.065, 0.05, 1], "metallicFactor": 0, "roughnessFactor": 1}},
    "green": {"pbrMetallicRoughness": {"baseColorFactor": [0.14, 0.45, 0.091, 1], "metallicFactor": 0, "roughnessFactor": 1}},
    "light": {"pbrMetallicRoughness": {"baseColorFactor": [0.78, 0.78, 0.78, 1], "metallicFactor": 0, "roughnessFactor": 1},
              "emissiveFactor": [1.0, 12 / 17, 4 / 17], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 17.0}}},
    "gold": {"pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.71, 0.29, 1], "metallicFactor": 1, "roughnessFactor": 0.3}},
}
names = list(materials)

buf = bytearray()
accessors, views, primitives = [], [], []

def add_view(data, target):
    while len(buf) % 4:
        buf.append(0)
    views.append({"buffer": 0, "byteOffset": len(buf), "byteLength": len(data), "target": target})
    buf.extend(data)
    return len(views) - 1

def add_primitive(mat, positions, normals, indices):
    pv = add_view(b"".join(struct.pack("<3f", *p) for p in positions), 34962)
    lo = [min(p[i] for p in positions) for i in range(3)]
    hi = [max(p[i] for p in positions) for i in range(3)]
    accessors.append({"bufferView": pv, "componentType": 5126, "count": len(positions), "type": "VEC3", "min": lo, "max": hi})
    attrs = {"POSITION": len(accessors) - 1}
    if normals:
        nv = add_view(b"".join(struct.pack("<3f", *n) for n in normals), 34962)
        accessors.append({"bufferView": nv, "componentType": 5126, "count": len(normals), "type": "VEC3"})
        attrs["NORMAL"] = len(accessors) - 1
    iv = add_view(b"".join(struct.pack("<H", i) for i in indices), 34963)
    accessors.append({"bufferView": iv, "componentType": 5123, "count": len(indices), "type": "SCALAR"})
    primitives.append({"attributes": attrs, "indices": len(accessors) - 1, "material": names.index(mat)})

for mat in ["white", "red", "green", "light"]:
    pos, idx = [], []
    for m, corners in quads:
        if m != mat:
            continue
        base = len(pos)
        pos.extend(corners)
        idx.extend([base, base + 1, base + 2, base, base + 2, base + 3])
    add_primitive(mat, pos, None, idx)

# Gold sphere, smooth normals.
cx, cy, cz, r = -0.38, 0.45, -0.3, 0.45
rings, segs = 24, 48
pos, nrm, idx = [], [], []
for i in range(rings + 1):
    th = math.pi * i / rings
    for j in range(segs + 1):
        ph = 2 * math.pi * j / segs
        n = (math.sin(th) * math.cos(ph), math.cos(th), -math.sin(th) * math.sin(ph))
        nrm.append(n)
        pos.append((cx + r * n[0], cy + r * n[1], cz + r * n[2]))
for i in range(rings):
    for j in range(segs):
        a, b = i * (segs + 1) + j, (i + 1) * (segs + 1) + j
        if i != 0:
            idx.extend([a, b, a + 1])
        if i != rings - 1:
            idx.extend([a + 1, b, b + 1])
add_primitive("gold", pos, nrm, idx)

doc = {
    "asset": {"version": "2.0", "generator": "Glint scenes/make_cornell_box.py"},
    "extensionsUsed": ["KHR_materials_emissive_strength"],
    "scene": 0,
    "scenes": [{"name": "Cornell box", "nodes": [0, 1]}],
    "nodes": [
        {"name": "Cornell box", "mesh": 0},
        {"name": "Camera", "camera": 0, "translation": [0, 1, 3.8]},
    ],
    "cameras": [{"name": "Camera", "type": "perspective", "perspective": {"yfov": 0.6911, "aspectRatio": 1.0, "znear": 0.1}}],
    "meshes": [{"name": "Cornell box", "primitives": primitives}],
    "materials": [dict(name=k, **v) for k, v in materials.items()],
    "buffers": [{"byteLength": len(buf), "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(buf)).decode()}],
    "bufferViews": views,
    "accessors": accessors,
}
def write(name, doc):
    out = pathlib.Path(__file__).with_name(name)
    out.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"wrote {out} ({len(buf)} bytes of geometry)")


write("cornell-box.gltf", doc)

diffuse = json.loads(json.dumps(doc))
diffuse["extensionsUsed"].append("KHR_materials_specular")
for m in diffuse["materials"]:
    if m["name"] == "gold":
        m["name"] = "white sphere"
        m["pbrMetallicRoughness"] = dict(materials["white"]["pbrMetallicRoughness"])
    m.setdefault("extensions", {})["KHR_materials_specular"] = {"specularFactor": 0.0}
write("cornell-box-diffuse.gltf", diffuse)
