#!/usr/bin/env python3
"""Evaluates Mitsuba 3.9.1's BSDFs (scalar_rgb) at fixed random direction pairs and writes the
values optik's BSDFs must reproduce into bsdf/<name>.json:

  {"name": ..., "bsdf": <the mi.load_dict dictionary>, "queries": [
      {"wi": [x, y, z], "wo": [x, y, z], "eval": [r, g, b], "pdf": p}, ...]}

Directions are in the local shading frame (normal +z). `eval` is Mitsuba's BSDF::eval, which
includes the cosine of wo; `pdf` is BSDF::pdf (solid angle); smooth (delta) BSDFs have zero eval
and pdf everywhere.

Each file also holds "samples": BSDF::sample at random incident directions and sample values,
{"wi", "u": [sample1, sample2.x, sample2.y], "wo", "weight", "pdf", "eta", "lobe"} with lobe
"delta", "null", "smooth" or "none" (no sample: zero weight). They pin down the discrete lobe
probabilities and weights of delta BSDFs, which a chi-square test cannot see.

Usage (after scripts/mitsuba-setup):
    .venv-mitsuba/bin/python render/validation/make_bsdf_values.py
"""
import json
import os

import mitsuba as mi
import numpy as np

mi.set_variant("scalar_rgb")
HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "bsdf")
QUERIES = 48

RGB = lambda r, g, b: {"type": "rgb", "value": [r, g, b]}

# Every parameter optik's Bsdf has is given explicitly, so the Rust side needs no defaults.
BSDFS = {
    "diffuse": {"type": "diffuse", "reflectance": RGB(0.2, 0.5, 0.8)},
    "twosided_diffuse": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": RGB(0.7, 0.4, 0.1)}},
    "roughconductor_beckmann": {
        "type": "roughconductor", "distribution": "beckmann", "alpha": 0.3, "sample_visible": True,
        "eta": RGB(0.2, 0.9, 1.1), "k": RGB(3.9, 2.4, 1.6), "specular_reflectance": RGB(1, 1, 1),
    },
    "roughconductor_ggx": {
        "type": "roughconductor", "distribution": "ggx", "alpha": 0.2, "sample_visible": True,
        "eta": RGB(0, 0, 0), "k": RGB(1, 1, 1), "specular_reflectance": RGB(0.9, 0.8, 0.7),
    },
    "roughconductor_ggx_anisotropic": {
        "type": "roughconductor", "distribution": "ggx", "alpha_u": 0.05, "alpha_v": 0.4, "sample_visible": True,
        "eta": RGB(1.65746, 0.880369, 0.521229), "k": RGB(9.22387, 6.26952, 4.837),
        "specular_reflectance": RGB(1, 1, 1),
    },
    "roughconductor_beckmann_no_visible": {
        "type": "roughconductor", "distribution": "beckmann", "alpha": 0.25, "sample_visible": False,
        "eta": RGB(0.143119, 0.374957, 1.44248), "k": RGB(3.98316, 2.38572, 1.60322),
        "specular_reflectance": RGB(1, 1, 1),
    },
    "roughdielectric_beckmann": {
        "type": "roughdielectric", "distribution": "beckmann", "alpha": 0.3, "sample_visible": True,
        "int_ior": 1.5, "ext_ior": 1.0,
        "specular_reflectance": RGB(1, 1, 1), "specular_transmittance": RGB(1, 1, 1),
    },
    "roughdielectric_ggx": {
        "type": "roughdielectric", "distribution": "ggx", "alpha": 0.1, "sample_visible": True,
        "int_ior": 1.5046, "ext_ior": 1.000277,
        "specular_reflectance": RGB(1, 1, 1), "specular_transmittance": RGB(0.9, 0.95, 1),
    },
    "plastic": {
        "type": "plastic", "diffuse_reflectance": RGB(0.1, 0.27, 0.36), "specular_reflectance": RGB(1, 1, 1),
        "int_ior": 1.9, "ext_ior": 1.000277, "nonlinear": False,
    },
    "plastic_nonlinear": {
        "type": "plastic", "diffuse_reflectance": RGB(0.6, 0.3, 0.1), "specular_reflectance": RGB(1, 1, 1),
        "int_ior": 1.49, "ext_ior": 1.000277, "nonlinear": True,
    },
    "roughplastic_beckmann": {
        "type": "roughplastic", "distribution": "beckmann", "alpha": 0.1,
        "diffuse_reflectance": RGB(0.1, 0.27, 0.36), "specular_reflectance": RGB(1, 1, 1),
        "int_ior": 1.49, "ext_ior": 1.000277, "nonlinear": False,
    },
    "roughplastic_ggx_nonlinear": {
        "type": "roughplastic", "distribution": "ggx", "alpha": 0.3, "nonlinear": True,
        "diffuse_reflectance": RGB(0.8, 0.8, 0.8), "specular_reflectance": RGB(1, 1, 1),
        "int_ior": 1.5, "ext_ior": 1.0,
    },
    "conductor_mirror": {"type": "conductor"},
    "conductor_au": {"type": "conductor", "material": "Au", "specular_reflectance": RGB(0.9, 0.8, 1.0)},
    "conductor_eta_k": {
        "type": "conductor", "eta": RGB(0.2, 0.9, 1.1), "k": RGB(3.9, 2.4, 1.6),
        "specular_reflectance": RGB(1, 1, 1),
    },
    "twosided_conductor": {"type": "twosided", "bsdf": {"type": "conductor", "material": "Cu"}},
    "dielectric": {
        "type": "dielectric", "int_ior": 1.5046, "ext_ior": 1.000277,
        "specular_reflectance": RGB(1, 0.9, 0.8), "specular_transmittance": RGB(0.9, 0.95, 1),
    },
    "thindielectric": {
        "type": "thindielectric", "int_ior": 1.33, "ext_ior": 1.0,
        "specular_reflectance": RGB(1, 0.9, 0.8), "specular_transmittance": RGB(0.9, 0.95, 1),
    },
}

# BSDFs with transmission or two sides are also queried from below the surface.
BOTH_SIDES = {"twosided_diffuse", "roughdielectric_beckmann", "roughdielectric_ggx",
              "twosided_conductor", "dielectric", "thindielectric"}
SAMPLES = 64


def uniform_sphere(rng):
    z = rng.uniform(-1.0, 1.0)
    phi = rng.uniform(0.0, 2.0 * np.pi)
    r = np.sqrt(max(0.0, 1.0 - z * z))
    return [r * np.cos(phi), r * np.sin(phi), z]


def queries(name, desc, rng):
    bsdf = mi.load_dict(desc)
    ctx = mi.BSDFContext()
    out = []
    for _ in range(QUERIES):
        wi = uniform_sphere(rng)
        if name not in BOTH_SIDES:
            wi[2] = abs(wi[2])
        wo = uniform_sphere(rng)
        if name not in BOTH_SIDES and rng.uniform() < 0.8:
            wo[2] = abs(wo[2])
        si = mi.SurfaceInteraction3f()
        si.p = [0, 0, 0]
        si.n = [0, 0, 1]
        si.sh_frame = mi.Frame3f(si.n)
        si.uv = [0.5, 0.5]
        si.wi = mi.Vector3f(wi)
        value = bsdf.eval(ctx, si, mi.Vector3f(wo))
        pdf = bsdf.pdf(ctx, si, mi.Vector3f(wo))
        out.append({
            "wi": [float(c) for c in wi],
            "wo": [float(c) for c in wo],
            "eval": [float(value[0]), float(value[1]), float(value[2])],
            "pdf": float(pdf),
        })
    return out


def samples(name, desc, rng):
    bsdf = mi.load_dict(desc)
    ctx = mi.BSDFContext()
    out = []
    for _ in range(SAMPLES):
        wi = uniform_sphere(rng)
        if name not in BOTH_SIDES:
            wi[2] = abs(wi[2])
        u = [float(x) for x in rng.uniform(0.0, 1.0, 3)]
        si = mi.SurfaceInteraction3f()
        si.p = [0, 0, 0]
        si.n = [0, 0, 1]
        si.sh_frame = mi.Frame3f(si.n)
        si.uv = [0.5, 0.5]
        si.wi = mi.Vector3f(wi)
        bs, weight = bsdf.sample(ctx, si, u[0], mi.Point2f(u[1], u[2]))
        if max(weight) == 0:
            lobe = "none"
        elif mi.has_flag(bs.sampled_type, mi.BSDFFlags.Null):
            lobe = "null"  # also Delta: Mitsuba's Delta flag includes Null
        elif mi.has_flag(bs.sampled_type, mi.BSDFFlags.Delta):
            lobe = "delta"
        else:
            lobe = "smooth"
        out.append({
            "wi": [float(c) for c in wi],
            "u": u,
            "wo": [float(c) for c in bs.wo],
            "weight": [float(weight[0]), float(weight[1]), float(weight[2])],
            "pdf": float(bs.pdf),
            "eta": float(bs.eta),
            "lobe": lobe,
        })
    return out


def main():
    os.makedirs(OUT, exist_ok=True)
    rng = np.random.default_rng(11)
    # A separate stream, so that adding samples left the earlier queries unchanged.
    sample_rng = np.random.default_rng(12)
    for name, desc in BSDFS.items():
        data = {"name": name, "mitsuba": mi.__version__, "variant": "scalar_rgb", "bsdf": desc,
                "queries": queries(name, desc, rng),
                "samples": samples(name, desc, sample_rng)}
        with open(os.path.join(OUT, name + ".json"), "w") as f:
            json.dump(data, f, indent=1)
            f.write("\n")
        nonzero = sum(1 for q in data["queries"] if max(q["eval"]) > 0)
        print(f"{name}: {len(data['queries'])} queries, {nonzero} with nonzero eval")


if __name__ == "__main__":
    main()
