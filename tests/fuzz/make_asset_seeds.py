#!/usr/bin/env python3
"""Writes tests/fuzz/asset_seeds/: one small valid input per importer for the asset fuzzer and the
mutation test (tests/fuzz/asset_fuzz_target.hpp): a first byte that picks the importer (0 OBJ+MTL,
1 glTF, 2 .glb, 3 mesh OBJ), the main file, then "\\n#side-file\\n" and the side file (MTL, .bin).
The glTF seeds are tests/data/assets/animated_box.gltf: with its buffer inline, as an external
.bin, and packed as .glb.
    python3 tests/fuzz/make_asset_seeds.py"""
import base64
import json
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
SEP = b"\n#side-file\n"

OBJ = b"""mtllib a.mtl
o quad
v -0.5 0 -0.5
v -0.5 0 0.5
v 0.5 0 0.5
v 0.5 0 -0.5
v 0 1 0
vt 0 1
vt 0 0
vt 1 0
vt 1 1
vn 0 1 0
usemtl paint
f 1/1/1 2/2/1 3/3/1
f 1/1/1 3/3/1 4/4/1
usemtl lamp
f 1 2 5
f 2 3 5 4
"""
MTL = b"""newmtl paint
Kd 0.8 0.2 0.1
Ks 0.5 0.5 0.5
Ns 250
d 1
map_Kd missing.png
newmtl lamp
Kd 0.1 0.1 0.1
Ke 2 2 2
Pr 0.3
Pm 0.5
"""
MESH_OBJ = b"""v -0.5 0 -0.5
v -0.5 0 0.5
v 0.5 0 0.5
v 0.5 0 -0.5
vn 0 1 0
f 1//1 2//1 3//1
f 1 3 4
"""


def write(name, kind, main, side=b""):
    with open(os.path.join(HERE, "asset_seeds", name), "wb") as f:
        f.write(bytes([kind]) + main + (SEP + side if side else b""))


def glb(gltf, binary):
    text = json.dumps(gltf, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    chunks = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(binary), 0x004E4942) + binary
    return struct.pack("<III", 0x46546C67, 2, 12 + len(chunks)) + chunks


def main():
    os.makedirs(os.path.join(HERE, "asset_seeds"), exist_ok=True)
    write("obj_mtl", 0, OBJ, MTL)
    write("mesh_obj", 3, MESH_OBJ)
    path = os.path.join(HERE, "..", "data", "assets", "animated_box.gltf")
    with open(path, "rb") as f:
        inline = f.read()
    write("gltf_inline", 1, inline)
    gltf = json.loads(inline)
    binary = base64.b64decode(gltf["buffers"][0]["uri"].split(",", 1)[1])
    gltf["buffers"][0]["uri"] = "a.bin"
    write("gltf_bin", 1, json.dumps(gltf, indent=1).encode(), binary)
    del gltf["buffers"][0]["uri"]
    write("glb", 2, glb(gltf, binary))


if __name__ == "__main__":
    main()
