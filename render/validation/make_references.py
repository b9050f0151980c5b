#!/usr/bin/env python3
"""Renders the reference estimates of the validation scenes with Mitsuba 3.9.1 (scalar_rgb).

For every scenes/<name>.xml (or the names given) it writes into references/:
  <name>_mean.exr  the mean radiance per pixel (RGB, float32),
  <name>_var.exr   the per-sample variance per pixel (RGB, float32),
  <name>.json      {"spp": total samples per pixel, "batches": ..., "variant": ..., ...}.

The variance comes from independent batches (seeds 0..B-1, spp/B samples each): the per-sample
variance is (spp/B) times the variance of the batch means, an unbiased estimate. Mitsuba's
`moment` integrator is not used because in RGB variants it records second moments of the
XYZ-converted samples, from which per-channel RGB variances cannot be recovered, and optik's
estimates are RGB.

Usage (after scripts/mitsuba-setup):
    nice .venv-mitsuba/bin/python render/validation/make_references.py [--spp N] [--batches B] [name ...]
"""
import argparse
import json
import os
import sys
import time

import mitsuba as mi
import numpy as np

VARIANT = "scalar_rgb"
HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(HERE, "scenes")
REFERENCES = os.path.join(HERE, "references")

# Samples per pixel per scene (total over all batches); a few minutes each on one core.
SPP = {
    "default": 16384,
    "breakfast_room": 4096,
}


def write_rgb(path, rgb):
    bmp = mi.Bitmap(np.ascontiguousarray(rgb, dtype=np.float32), mi.Bitmap.PixelFormat.RGB)
    bmp.write(path)


def render(name, spp, batches):
    scene = mi.load_file(os.path.join(SCENES, name + ".xml"))
    per_batch = max(1, spp // batches)
    s1 = None
    s2 = None
    start = time.time()
    for b in range(batches):
        img = np.array(mi.render(scene, spp=per_batch, seed=b), dtype=np.float64)[..., :3]
        s1 = img if s1 is None else s1 + img
        s2 = img * img if s2 is None else s2 + img * img
    mean = s1 / batches
    # Unbiased variance of the batch means, scaled to one sample.
    batch_var = np.maximum(s2 / batches - mean * mean, 0.0) * batches / (batches - 1)
    var = batch_var * per_batch
    seconds = time.time() - start
    write_rgb(os.path.join(REFERENCES, name + "_mean.exr"), mean)
    write_rgb(os.path.join(REFERENCES, name + "_var.exr"), var)
    meta = {
        "scene": f"scenes/{name}.xml",
        "spp": per_batch * batches,
        "batches": batches,
        "variant": VARIANT,
        "mitsuba": mi.__version__,
        "seconds": round(seconds, 1),
        "width": int(mean.shape[1]),
        "height": int(mean.shape[0]),
    }
    with open(os.path.join(REFERENCES, name + ".json"), "w") as f:
        json.dump(meta, f, indent=2)
        f.write("\n")
    print(f"{name}: {meta['spp']} spp in {seconds:.1f} s, mean {mean.mean(axis=(0, 1))}", flush=True)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("names", nargs="*", help="scene names (default: every scenes/*.xml)")
    parser.add_argument("--spp", type=int, help="samples per pixel (default: per scene, see SPP)")
    parser.add_argument("--batches", type=int, default=64, help="independent batches (default 64)")
    args = parser.parse_args()
    if args.batches < 2:
        sys.exit("--batches must be at least 2 to estimate a variance")
    mi.set_variant(VARIANT)
    names = args.names or sorted(f[:-4] for f in os.listdir(SCENES) if f.endswith(".xml"))
    os.makedirs(REFERENCES, exist_ok=True)
    for name in names:
        spp = args.spp or SPP.get(name, SPP["default"])
        render(name, spp, args.batches)


if __name__ == "__main__":
    main()
