#!/usr/bin/env python3
"""Builds the Breakfast Room validation scene from the project's merged OBJ of it.

Reads <source>/breakfast_room.obj (one OBJ with `usemtl <Mitsuba bsdf id>`, see that folder's
SOURCE.md) and <source>/scene.mitsuba.xml (the original Mitsuba 0.5 scene), and writes
  scenes/breakfast_room/<material>[_flat].obj  one OBJ per material (and per shading: meshes that
                                               were flat shaded in the original, written without
                                               normals, go to `_flat` files loaded with
                                               face_normals), plus the textures, copied;
  scenes/breakfast_room.xml                    a Mitsuba 3 scene: the original camera and BSDFs
                                               (property names upgraded to Mitsuba 3's), a small
                                               image, and the `sunsky` emitter replaced by a
                                               `directional` sun and a `constant` sky.
The meshes (27 MB) are not committed; the test that renders the scene says to run this script
when they are missing. Usage:
    python3 render/validation/make_breakfast_room.py [--source /work/shared/scenes/breakfast-room]
"""
import argparse
import os
import re
import shutil
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


def split_obj(source):
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
    os.makedirs(OUT, exist_ok=True)
    files = []
    for (material, flat), faces in sorted(groups.items()):
        name = material + ("_flat" if flat else "")
        remap = [{}, {}, {}]
        lines = [[], [], []]
        out_faces = []
        for corners in faces:
            out = []
            for c in corners:
                idx = []
                for k, table, prefix in ((0, v, "v"), (1, vt, "vt"), (2, vn, "vn")):
                    if k < len(c) and c[k] != "" and not (k == 2 and flat):
                        i = int(c[k])
                        i = i - 1 if i > 0 else len(table) + i
                        if i not in remap[k]:
                            remap[k][i] = len(remap[k]) + 1
                            lines[k].append(f"{prefix} {table[i]}")
                        idx.append(str(remap[k][i]))
                    else:
                        idx.append("")
                out.append("/".join(idx).rstrip("/"))
            out_faces.append("f " + " ".join(out))
        with open(os.path.join(OUT, name + ".obj"), "w") as f:
            f.write(f"# breakfast_room material {material} (make_breakfast_room.py)\n")
            for block in lines + [out_faces]:
                f.write("\n".join(block))
                if block:
                    f.write("\n")
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
    args = parser.parse_args()
    files = split_obj(args.source)
    textures = os.path.join(args.source, "textures")
    os.makedirs(os.path.join(OUT, "textures"), exist_ok=True)
    for t in os.listdir(textures):
        shutil.copyfile(os.path.join(textures, t), os.path.join(OUT, "textures", t))
    materials, fov, matrix = bsdfs(args.source)
    sun = tuple(-c for c in SUN_TOWARDS)
    shapes = []
    for name, material, flat, count in files:
        normals = '\n        <boolean name="face_normals" value="true"/>' if flat else ""
        shapes.append(f"""    <shape type="obj">
        <string name="filename" value="breakfast_room/{name}.obj"/>{normals}
        <ref id="{material}"/>
    </shape>""")
    xml = f"""<scene version="3.0.0">
    <!-- The Breakfast Room ("The Breakfast Room" by Wig42, Blend Swap; Mitsuba version by
         Benedikt Bitterli; CC BY 3.0, see render/validation/SOURCE.md), one
         OBJ per material, written by make_breakfast_room.py: run it to create the meshes.
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
