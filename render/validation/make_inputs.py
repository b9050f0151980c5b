#!/usr/bin/env python3
"""Writes the small input files the validation scenes use, so that none is copied from elsewhere.

- scenes/textures/checker.png: 64x64 8-bit sRGB texture (bitmap lookups, sRGB decoding,
  bilinear filtering, uv orientation: the colours differ per quadrant and along u and v);
- scenes/textures/envmap.exr: 64x32 float latitude-longitude sky with a bright sun patch;
- scenes/meshes/rectangle_uv.obj: a quad with per-vertex normals and uvs, as Mitsuba's
  rectangle_normals_uv.obj test mesh has.

Run with the venv from scripts/mitsuba-setup (it needs numpy and mitsuba for image writing):
    .venv-mitsuba/bin/python render/validation/make_inputs.py
"""
import os

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(HERE, "scenes")


def checker():
    n = 64
    v, u = np.mgrid[0:n, 0:n] / (n - 1.0)
    cells = ((np.floor(u * 8) + np.floor(v * 8)) % 2)[..., None]
    base = np.stack([0.15 + 0.8 * u, 0.2 + 0.6 * v, 0.9 - 0.7 * u * v], axis=-1)
    rgb = base * (0.45 + 0.55 * cells)
    img = np.clip(np.round(rgb * 255.0), 0, 255).astype(np.uint8)
    bmp = mi.Bitmap(img, mi.Bitmap.PixelFormat.RGB)
    bmp.set_srgb_gamma(True)
    bmp.write(os.path.join(SCENES, "textures", "checker.png"))


def envmap():
    w, h = 64, 32
    y, x = np.mgrid[0:h, 0:w]
    theta = (y + 0.5) / h * np.pi  # 0 at the top row (Mitsuba's +y up)
    phi = (x + 0.5) / w * 2.0 * np.pi
    sky = np.stack([0.3 + 0.5 * np.cos(theta / 2), 0.4 + 0.4 * np.cos(theta / 2), 0.9 - 0.3 * theta / np.pi], -1)
    ground = np.array([0.25, 0.2, 0.15])
    rgb = np.where((theta < np.pi / 2)[..., None], sky, ground)
    rgb = rgb * (0.8 + 0.2 * np.sin(3 * phi))[..., None]
    sun = (np.abs(y - 8) <= 1) & (np.abs(x - 20) <= 1)
    rgb[sun] = [40.0, 36.0, 30.0]
    bmp = mi.Bitmap(rgb.astype(np.float32), mi.Bitmap.PixelFormat.RGB)
    bmp.write(os.path.join(SCENES, "textures", "envmap.exr"))


def rectangle_obj():
    text = """# A unit quad in z = 0 facing +z with normals and uvs (written by make_inputs.py).
v -1 -1 0
v 1 -1 0
v 1 1 0
v -1 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
f 1/1/1 2/2/1 3/3/1
f 1/1/1 3/3/1 4/4/1
"""
    with open(os.path.join(SCENES, "meshes", "rectangle_uv.obj"), "w") as f:
        f.write(text)


if __name__ == "__main__":
    for d in ("textures", "meshes"):
        os.makedirs(os.path.join(SCENES, d), exist_ok=True)
    checker()
    envmap()
    rectangle_obj()
    print("inputs written under", SCENES)
