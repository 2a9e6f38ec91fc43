"""Write the test sky of the README's *How it renders* (the World): a
512 × 256 equirectangular Radiance HDR, blue above the horizon and brown
below, with a sun 2° in radius of radiance (3000, 2800, 2500) at 34°
elevation — a small, very bright light of the kind an HDRI photograph
holds. With a render request (JSON, as the add-on or
`tests/blender/convergence.py --export` writes it), also write a copy that
lights the scene by this sky alone: its environment set, its area lights
removed.

    python3 scenes/sky_with_sun.py OUT_DIR [REQUEST.json]

Needs numpy (the bpy virtualenv has it)."""

import json
import sys
from pathlib import Path

import numpy as np

WIDTH, HEIGHT = 512, 256
SUN = np.array([3000.0, 2800.0, 2500.0])


def sky():
    """Radiance, top row first, in Blender's Z-up directions (u = ½ −
    atan2(y, x)/2π, v = θ/π), as Glint and Cycles read the image."""
    v = (np.arange(HEIGHT) + 0.5) / HEIGHT
    u = (np.arange(WIDTH) + 0.5) / WIDTH
    theta, phi = np.pi * v[:, None], 2 * np.pi * (0.5 - u[None, :])
    d = np.stack([np.sin(theta) * np.cos(phi), np.sin(theta) * np.sin(phi), np.cos(theta) * np.ones_like(phi)], axis=-1)
    up = d[..., 2:3]
    rgb = np.where(up > 0, np.array([0.35, 0.55, 1.0]) * (0.4 + 0.6 * (1 - up)), np.array([0.25, 0.22, 0.2]))
    elevation, azimuth = 0.6, 1.0
    sun_dir = np.array([np.cos(elevation) * np.cos(azimuth), np.cos(elevation) * np.sin(azimuth), np.sin(elevation)])
    rgb[(d * sun_dir).sum(axis=-1) > np.cos(np.radians(2.0))] = SUN
    return rgb


def write_hdr(path, rgb):
    """Flat RGBE scanlines, top row first."""
    m = rgb.max(axis=-1)
    e = np.ceil(np.log2(np.maximum(m, 1e-32)))
    scale = np.where(m > 1e-32, 256.0 / np.exp2(e), 0.0)
    out = np.zeros(rgb.shape[:2] + (4,), np.uint8)
    out[..., :3] = np.clip(rgb * scale[..., None], 0, 255).astype(np.uint8)
    out[..., 3] = np.where(m > 1e-32, e + 128, 0).astype(np.uint8)
    with open(path, "wb") as f:
        f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + f"-Y {HEIGHT} +X {WIDTH}\n".encode())
        f.write(out.tobytes())


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    out = Path(sys.argv[1])
    out.mkdir(parents=True, exist_ok=True)
    write_hdr(out / "sky.hdr", sky())
    if len(sys.argv) == 3:
        request = json.loads(Path(sys.argv[2]).read_text())
        request.pop("background", None)
        request["environment"] = {"image": str((out / "sky.hdr").resolve()), "strength": 1.0, "rotation": 0.0}
        request["area_lights"] = []
        (out / "request.json").write_text(json.dumps(request, indent=1))


if __name__ == "__main__":
    main()
