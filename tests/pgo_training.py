"""The training renders of a profile-guided build (tests/pgo-build): every
kernel Glint can choose (src/render.rs: six BSDFs — Lambert, the seed's,
the seed's with glass, Principled, Principled with glass, Principled
with a coat (and glass, where there is some) — times six sets
of light parts), each on a small variant of the project's own Cornell
boxes, at 1 spp (independent numbers) and 4 (Sobol), with light subpaths
as `auto` picks them; then the boxes and the Khronos samples as a user
renders them. A kernel left out of the training would be compiled as cold
code: a window room's kernel, untrained, rendered 26% slower than without
any profile.

    python3 tests/pgo_training.py GLINT WORK_DIR [SHARED_DIR]

Prints each kernel it trained; exits non-zero, naming the render, if a
render fails or picks another kernel than the one it trains.
"""

import copy
import json
import os
import subprocess
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

# The light parts of a kernel (area, punctual, lamps), by what the scene
# holds: emitting triangles, a point light, area lights of a request.
LIGHTS = {
    "no local lights": dict(emitter=False, point=False, lamps=False),
    "punctual": dict(emitter=False, point=True, lamps=False),
    "emitters": dict(emitter=True, point=False, lamps=False),
    "emitters + lamps": dict(emitter=True, point=False, lamps=True),
    "emitters + punctual": dict(emitter=True, point=True, lamps=False),
    "emitters + lamps + punctual": dict(emitter=True, point=True, lamps=True),
}
# (kernel name, scene, --bsdf, glass, coat)
BSDFS = [
    ("lambert", "cornell-box-diffuse.gltf", "principled", False, False),
    ("seed", "cornell-box.gltf", "seed", False, False),
    ("seed + glass", "cornell-box.gltf", "seed", True, False),
    ("principled", "cornell-box.gltf", "principled", False, False),
    ("principled + glass", "cornell-box.gltf", "principled", True, False),
    ("principled + coat", "cornell-box.gltf", "principled", False, True),
]


def variant(scene, emitter, point, glass, coat=False):
    """The box without its emitter, with a point light, with its sphere
    made of glass, with a clear coat on its white walls, as asked."""
    gltf = copy.deepcopy(scene)
    used = set(gltf.get("extensionsUsed", []))
    if not emitter:
        for m in gltf["materials"]:
            m.pop("emissiveFactor", None)
            m.get("extensions", {}).pop("KHR_materials_emissive_strength", None)
    if point:
        used.add("KHR_lights_punctual")
        gltf.setdefault("extensions", {})["KHR_lights_punctual"] = {"lights": [{"type": "point", "color": [1, 0.9, 0.8], "intensity": 40}]}
        gltf["nodes"].append({"name": "Bulb", "translation": [0.3, 1.6, 0.2], "extensions": {"KHR_lights_punctual": {"light": 0}}})
        gltf["scenes"][gltf.get("scene", 0)]["nodes"].append(len(gltf["nodes"]) - 1)
    if glass:
        used.add("KHR_materials_transmission")
        sphere = gltf["materials"][-1]
        sphere["pbrMetallicRoughness"] = {"baseColorFactor": [1, 1, 1, 1], "metallicFactor": 0, "roughnessFactor": 0.1}
        sphere.setdefault("extensions", {})["KHR_materials_transmission"] = {"transmissionFactor": 1}
    if coat:
        used.add("KHR_materials_clearcoat")
        floor = gltf["materials"][0]
        floor.setdefault("extensions", {})["KHR_materials_clearcoat"] = {"clearcoatFactor": 1, "clearcoatRoughnessFactor": 0.05}
    gltf["extensionsUsed"] = sorted(used)
    return gltf


def request(lamps, portal):
    """A grey World; 16 small lamps under the ceiling (y = 1.9 m in the
    glTF's Y-up metres, facing down) and a portal over the open front
    (z = 1 m, facing in), where asked."""
    r = {"background": [0.1, 0.1, 0.1]}
    if portal:
        r["background"] = [1.8, 1.9, 2.0]
        r["area_lights"] = [{"name": "Portal", "shape": "RECTANGLE", "size": [2, 2], "color": [1, 1, 1], "power": 1, "portal": True,
                             "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 1, 1, 1]}]
    if lamps:
        r["area_lights"] = [
            {"name": f"Lamp {i}", "shape": "SQUARE", "size": [0.2, 0.2], "color": [1, 0.9, 0.8], "power": 20,
             "matrix": [1, 0, 0, 0, 0, 0, -1, 0, 0, 1, 0, 0, -0.75 + 0.5 * (i % 4), 1.9, -0.75 + 0.5 * (i // 4), 1]}
            for i in range(16)
        ]
    return r


def kernel_of(stderr):
    """The kernel a render's features line names, without what it adds
    to it (" + light paths", " + light tree (…)")."""
    line = next((l for l in stderr.splitlines() if "kernel: " in l), "")
    parts = line.split("kernel: ")[-1].split(" + ")
    return " + ".join(p for p in parts if p != "light paths" and not p.startswith("light tree"))


def render(glint, args, kernel=None):
    out = subprocess.run([glint, "render", "--threads", "2", *args], capture_output=True, text=True)
    line = " ".join(["glint render", *args])
    if out.returncode != 0:
        sys.exit(f"pgo_training: failed: {line}: {out.stderr.strip().splitlines()[-1:]}")
    if kernel is not None and kernel_of(out.stderr) != kernel:
        sys.exit(f"pgo_training: {line} did not run kernel '{kernel}': {out.stderr.strip()}")


def main():
    glint, work = sys.argv[1], sys.argv[2]
    shared = sys.argv[3] if len(sys.argv) > 3 else os.path.join(ROOT, "..", "shared")
    os.makedirs(work, exist_ok=True)
    out = os.path.join(work, "out.exr")
    for bsdf_name, scene_file, model, glass, coat in BSDFS:
        scene = json.load(open(os.path.join(ROOT, "scenes", scene_file)))
        for lights_name, parts in LIGHTS.items():
            name = f"{bsdf_name} + {lights_name}"
            path = os.path.join(work, name.replace(" + ", "-").replace(" ", "_"))
            with open(path + ".gltf", "w") as f:
                json.dump(variant(scene, parts["emitter"], parts["point"], glass, coat), f)
            with open(path + ".json", "w") as f:
                json.dump(request(parts["lamps"], portal=lights_name == "no local lights"), f)
            for spp in ("1", "4"):
                render(glint, [path + ".gltf", "--request", path + ".json", "--bsdf", model, "--width", "64", "--spp", spp, "-o", out], kernel=name)
            print(f"trained kernel: {name}", flush=True)
    # As a user renders them: larger, and the samples framed by `auto`.
    render(glint, ["--width", "128", "--spp", "4", "-o", out])
    render(glint, ["--width", "128", "--spp", "1", "-o", out])
    render(glint, [os.path.join(ROOT, "scenes", "cornell-box-diffuse.gltf"), "--width", "128", "--spp", "4", "-o", out])
    samples = os.path.join(shared, "gltf-samples")
    for sample in sorted(os.listdir(samples)) if os.path.isdir(samples) else []:
        folder = os.path.join(samples, sample)
        for file in sorted(os.listdir(folder)) if os.path.isdir(folder) else []:
            if file.endswith((".gltf", ".glb")):
                render(glint, [os.path.join(folder, file), "--camera", "auto", "--width", "64", "--spp", "4", "-o", out])


if __name__ == "__main__":
    main()
