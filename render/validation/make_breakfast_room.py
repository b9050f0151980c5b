#!/usr/bin/env python3
"""Builds the Breakfast Room validation scene from the project's merged OBJ of it.

Reads <source>/breakfast_room.obj (one OBJ with `usemtl <Mitsuba bsdf id>`, see that folder's
SOURCE.md) and <source>/scene.mitsuba.xml (the original Mitsuba 0.5 scene), and writes
  scenes/breakfast_room/<material>[_flat].ply  one binary PLY per material (and per shading:
                                               meshes that were flat shaded in the original,
                                               written without normals, go to `_flat` files
                                               loaded with face_normals), plus the textures,
                                               copied; all committed (7.7 MB of meshes) so CI
                                               renders the scene;
  scenes/breakfast_room.xml                    a Mitsuba 3 scene: the original camera and BSDFs
                                               (property names upgraded to Mitsuba 3's), a small
                                               image, and the `sunsky` emitter replaced by a
                                               `directional` sun and a `constant` sky.
The PLY meshes hold exactly what an OBJ reader makes of the per-material OBJs this script wrote
before (the references were rendered from those): `--obj-dir DIR` writes those OBJs too, and the
ignored test `breakfast_room_ply_matches_obj` in render/tests/scene_mitsuba.rs compares the two
bit for bit. Usage:
    python3 render/validation/make_breakfast_room.py [--source /work/shared/scenes/breakfast-room]
        [--obj-dir target/tmp/breakfast_room_obj]
"""
import argparse
import os
from fractions import Fraction
import shutil
import struct
import xml.etree.ElementTree as ET

HERE = os.path.dirname(os.path.abspath(__file__))
SCENES = os.path.join(HERE, "scenes")
OUT = os.path.join(SCENES, "breakfast_room")

WIDTH, HEIGHT = 64, 36
MAX_DEPTH = 6
# The sun of the original sunsky (sunDirection points towards the sun) and a sky colour.
SUN_TOWARDS = (0.88698, 0.288862, 0.360313)
SUN_IRRADIANCE = (40.0, 36.0, 30.0)
SKY_RADIANCE = (1.2, 1.5, 2.0)

RENAMES = {
    "diffuseReflectance": "diffuse_reflectance",
    "specularReflectance": "specular_reflectance",
    "intIOR": "int_ior",
    "extIOR": "ext_ior",
    "filterType": "filter_type",
}
DROPPED = {"extEta"}  # Mitsuba 3's roughconductor has no exterior index (it is 1 here anyway).


def f32_nearest(exact, guess):
    """The float32 nearest to the rational `exact` (ties to even), searched around `guess`."""
    bits = struct.unpack("<I", struct.pack("<f", guess))[0]
    best = None
    for b in (bits - 1, bits, bits + 1):
        if not 0 <= b < 0x7F800000 and not 0x80000000 <= b < 0xFF800000:
            continue
        value = struct.unpack("<f", struct.pack("<I", b))[0]
        key = (abs(Fraction(value) - exact), b & 1)
        if best is None or key < best[0]:
            best = (key, value)
    return best[1]


def is_f32_midpoint(d):
    """Whether the float64 `d` lies exactly halfway between two float32s."""
    bits = struct.unpack("<Q", struct.pack("<d", d))[0]
    return bits & ((1 << 29) - 1) == 1 << 28


def parse_f32(text):
    """A decimal as the OBJ readers parse it: rounded once to the nearest float32. Rounding
    through float64 differs from that only when the float64 is a float32 midpoint."""
    d = float(text)
    if is_f32_midpoint(d):
        return f32_nearest(Fraction(text), d)
    return struct.unpack("<f", struct.pack("<f", d))[0]


def one_minus_f32(v):
    """1 - v in float32 arithmetic (Mitsuba's and optik's `flip_tex_coords` on OBJ files)."""
    d = 1.0 - v  # exact in float64 unless v is tiny
    if (v != 0.0 and abs(v) < 2.0**-28) or is_f32_midpoint(d):
        return f32_nearest(1 - Fraction(v), d)
    return struct.unpack("<f", struct.pack("<f", d))[0]


def split_faces(source):
    """The merged OBJ's triangles grouped by (material, flat), with its vertex tables as text."""
    v, vt, vn = [], [], []
    groups = {}
    material = "default"
    with open(os.path.join(source, "breakfast_room.obj")) as f:
        for line in f:
            if line.startswith("v "):
                v.append(line[2:].strip())
            elif line.startswith("vt "):
                vt.append(line[3:].strip())
            elif line.startswith("vn "):
                vn.append(line[3:].strip())
            elif line.startswith("usemtl "):
                material = line.split()[1]
            elif line.startswith("f "):
                corners = [c.split("/") for c in line.split()[1:]]
                flat = any(len(c) < 3 or c[2] == "" for c in corners)
                groups.setdefault((material, flat), []).append(corners)
    return (v, vt, vn), groups


def corner_indices(corners, tables, flat):
    """Per corner, the 0-based (position, uv, normal) indices, None where absent."""
    out = []
    for c in corners:
        idx = []
        for k in range(3):
            if k < len(c) and c[k] != "" and not (k == 2 and flat):
                i = int(c[k])
                idx.append(i - 1 if i > 0 else len(tables[k]) + i)
            else:
                idx.append(None)
        out.append(tuple(idx))
    return out


def write_obj(path, material, faces, tables, flat):
    """One material's faces as an OBJ (the format the meshes had before they became PLY; kept
    for `--obj-dir`, which the conversion check compares against)."""
    remap = [{}, {}, {}]
    lines = [[], [], []]
    out_faces = []
    for corners in faces:
        out = []
        for key in corner_indices(corners, tables, flat):
            idx = []
            for k, prefix in enumerate(("v", "vt", "vn")):
                i = key[k]
                if i is None:
                    idx.append("")
                    continue
                if i not in remap[k]:
                    remap[k][i] = len(remap[k]) + 1
                    lines[k].append(f"{prefix} {tables[k][i]}")
                idx.append(str(remap[k][i]))
            out.append("/".join(idx).rstrip("/"))
        out_faces.append("f " + " ".join(out))
    with open(path, "w") as f:
        f.write(f"# breakfast_room material {material} (make_breakfast_room.py)\n")
        for block in lines + [out_faces]:
            f.write("\n".join(block))
            if block:
                f.write("\n")


def write_ply(path, material, faces, tables, flat):
    """One material's triangles as binary little-endian PLY with exactly the vertices, normals,
    uvs and triangles an OBJ reader (optik's tobj, Mitsuba's obj) makes of the OBJ: one vertex
    per distinct (position, uv, normal) corner in order of first use, every value rounded once
    from its decimal to float32, and v flipped to 1 - v in float32 as OBJ readers do by default
    (`flip_tex_coords`), since the PLY readers do not flip."""
    vertices = {}
    triangles = []
    for corners in faces:
        keys = corner_indices(corners, tables, flat)
        if len(keys) != 3:
            raise SystemExit(f"a face of {material} has {len(keys)} corners; expected triangles")
        triangles.append([vertices.setdefault(key, len(vertices)) for key in keys])
    keys = list(vertices)
    has_uv = all(k[1] is not None for k in keys)
    has_normal = all(k[2] is not None for k in keys)
    if any(k[1] is not None for k in keys) != has_uv or any(k[2] is not None for k in keys) != has_normal:
        raise SystemExit(f"{material}: some corners have uvs or normals and some do not")
    props = ["x", "y", "z"] + (["nx", "ny", "nz"] if has_normal else []) + (["u", "v"] if has_uv else [])
    header = "ply\nformat binary_little_endian 1.0\n"
    header += f"comment breakfast_room material {material} (make_breakfast_room.py)\n"
    header += f"element vertex {len(keys)}\n"
    header += "".join(f"property float {p}\n" for p in props)
    header += f"element face {len(triangles)}\nproperty list uchar uint vertex_indices\nend_header\n"
    vertex = struct.Struct("<" + "f" * len(props))
    face = struct.Struct("<B3I")
    with open(path, "wb") as f:
        f.write(header.encode("ascii"))
        for p, t, n in keys:
            values = [parse_f32(x) for x in tables[0][p].split()[:3]]
            if has_normal:
                values += [parse_f32(x) for x in tables[2][n].split()[:3]]
            if has_uv:
                u, v = (parse_f32(x) for x in tables[1][t].split()[:2])
                values += [u, one_minus_f32(v)]
            f.write(vertex.pack(*values))
        for tri in triangles:
            f.write(face.pack(3, *tri))


def split_obj(source, obj_dir):
    tables, groups = split_faces(source)
    os.makedirs(OUT, exist_ok=True)
    for old in os.listdir(OUT):
        if old.endswith((".obj", ".ply")):
            os.remove(os.path.join(OUT, old))
    files = []
    for (material, flat), faces in sorted(groups.items()):
        name = material + ("_flat" if flat else "")
        write_ply(os.path.join(OUT, name + ".ply"), material, faces, tables, flat)
        if obj_dir:
            os.makedirs(obj_dir, exist_ok=True)
            write_obj(os.path.join(obj_dir, name + ".obj"), material, faces, tables, flat)
        files.append((name, material, flat, len(faces)))
    return files


def bsdfs(source):
    tree = ET.parse(os.path.join(source, "scene.mitsuba.xml"))
    out = []
    for b in tree.getroot().findall("bsdf"):
        for e in b.iter():
            name = e.get("name")
            if name in RENAMES:
                e.set("name", RENAMES[name])
            if e.get("name") == "filter_type" and e.get("value") == "trilinear":
                e.set("value", "bilinear")  # Mitsuba 3's bitmap has nearest and bilinear only.
            if e.get("name") == "filename":
                e.set("value", "breakfast_room/" + e.get("value"))
        for parent in b.iter():
            for child in list(parent):
                if child.get("name") in DROPPED:
                    parent.remove(child)
        ET.indent(b, space="    ", level=1)
        out.append("    " + ET.tostring(b, encoding="unicode").strip())
    camera = tree.getroot().find("sensor")
    fov = camera.find("float[@name='fov']").get("value")
    matrix = camera.find("transform/matrix").get("value")
    return out, fov, matrix


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--source", default="/work/shared/scenes/breakfast-room")
    parser.add_argument("--obj-dir", help="also write the per-material OBJs here (for the check)")
    args = parser.parse_args()
    files = split_obj(args.source, args.obj_dir)
    textures = os.path.join(args.source, "textures")
    os.makedirs(os.path.join(OUT, "textures"), exist_ok=True)
    for t in os.listdir(textures):
        shutil.copyfile(os.path.join(textures, t), os.path.join(OUT, "textures", t))
    materials, fov, matrix = bsdfs(args.source)
    sun = tuple(-c for c in SUN_TOWARDS)
    shapes = []
    for name, material, flat, count in files:
        normals = '\n        <boolean name="face_normals" value="true"/>' if flat else ""
        shapes.append(f"""    <shape type="ply">
        <string name="filename" value="breakfast_room/{name}.ply"/>{normals}
        <ref id="{material}"/>
    </shape>""")
    xml = f"""<scene version="3.0.0">
    <!-- The Breakfast Room ("The Breakfast Room" by Wig42, Blend Swap; Mitsuba version by
         Benedikt Bitterli; CC BY 3.0, see render/validation/SOURCE.md), one
         PLY per material, written by make_breakfast_room.py.
         The original sunsky emitter is replaced by a directional sun and a constant sky. -->
    <default name="spp" value="64"/>

    <integrator type="path">
        <integer name="max_depth" value="{MAX_DEPTH}"/>
    </integrator>

    <sensor type="perspective">
        <float name="fov" value="{fov}"/>
        <string name="fov_axis" value="x"/>
        <transform name="to_world">
            <matrix value="{matrix}"/>
        </transform>
        <film type="hdrfilm">
            <integer name="width" value="{WIDTH}"/>
            <integer name="height" value="{HEIGHT}"/>
            <rfilter type="box"/>
            <string name="pixel_format" value="rgb"/>
            <string name="component_format" value="float32"/>
        </film>
        <sampler type="independent">
            <integer name="sample_count" value="$spp"/>
        </sampler>
    </sensor>

    <emitter type="directional">
        <vector name="direction" x="{sun[0]}" y="{sun[1]}" z="{sun[2]}"/>
        <rgb name="irradiance" value="{', '.join(map(str, SUN_IRRADIANCE))}"/>
    </emitter>
    <emitter type="constant">
        <rgb name="radiance" value="{', '.join(map(str, SKY_RADIANCE))}"/>
    </emitter>

{chr(10).join(materials)}

{chr(10).join(shapes)}
</scene>
"""
    with open(os.path.join(SCENES, "breakfast_room.xml"), "w") as f:
        f.write(xml)
    print(f"{len(files)} meshes, {sum(c for *_, c in files)} triangles; scenes/breakfast_room.xml written")


if __name__ == "__main__":
    main()
