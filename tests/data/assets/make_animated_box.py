#!/usr/bin/env python3
"""Writes animated_box.gltf: a unit box on node "mover" (child of "root", translated +0.5 Y) whose
translation runs (-1, 0, 0) -> (1, 0, 0) and rotation 0 -> 90 degrees about +Y over 0..1 s (LINEAR).
The test (tests/asset_test.cpp) checks the tracer places it exactly as these numbers say."""
import base64, json, math, struct

faces = [  # normal, two tangent axes
    ((1, 0, 0), (0, 1, 0), (0, 0, 1)), ((-1, 0, 0), (0, 0, 1), (0, 1, 0)),
    ((0, 1, 0), (0, 0, 1), (1, 0, 0)), ((0, -1, 0), (1, 0, 0), (0, 0, 1)),
    ((0, 0, 1), (1, 0, 0), (0, 1, 0)), ((0, 0, -1), (0, 1, 0), (1, 0, 0)),
]
pos, nrm, idx = [], [], []
for n, a, b in faces:
    base = len(pos)
    for s, t in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
        pos.append(tuple(0.5 * n[k] + 0.5 * s * a[k] + 0.5 * t * b[k] for k in range(3)))
        nrm.append(n)
    idx += [base, base + 1, base + 2, base, base + 2, base + 3]
times = [0.0, 1.0]
translations = [(-1.0, 0.0, 0.0), (1.0, 0.0, 0.0)]
h = math.sqrt(0.5)
rotations = [(0.0, 0.0, 0.0, 1.0), (0.0, h, 0.0, h)]  # x, y, z, w: 90 degrees about +Y

blob = b"".join(struct.pack("<3f", *p) for p in pos)
blob += b"".join(struct.pack("<3f", *n) for n in nrm)
blob += b"".join(struct.pack("<H", i) for i in idx)
blob += b"\0" * ((4 - len(blob) % 4) % 4)
o_time = len(blob)
blob += b"".join(struct.pack("<f", t) for t in times)
o_tr = len(blob)
blob += b"".join(struct.pack("<3f", *v) for v in translations)
o_rot = len(blob)
blob += b"".join(struct.pack("<4f", *q) for q in rotations)
nv = len(pos)
doc = {
    "asset": {"version": "2.0", "generator": "tests/data/assets/make_animated_box.py"},
    "scene": 0,
    "scenes": [{"nodes": [0]}],
    "nodes": [{"name": "root", "translation": [0, 0.5, 0], "children": [1]},
              {"name": "mover", "mesh": 0}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2,
                                "material": 0}]}],
    "materials": [{"name": "red", "pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.2, 0.1, 1],
                                                           "metallicFactor": 0, "roughnessFactor": 0.6}}],
    "buffers": [{"byteLength": len(blob),
                 "uri": "data:application/octet-stream;base64," + base64.b64encode(blob).decode()}],
    "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 12 * nv},
                    {"buffer": 0, "byteOffset": 12 * nv, "byteLength": 12 * nv},
                    {"buffer": 0, "byteOffset": 24 * nv, "byteLength": 2 * len(idx)},
                    {"buffer": 0, "byteOffset": o_time, "byteLength": 8},
                    {"buffer": 0, "byteOffset": o_tr, "byteLength": 24},
                    {"buffer": 0, "byteOffset": o_rot, "byteLength": 32}],
    "accessors": [
        {"bufferView": 0, "componentType": 5126, "count": nv, "type": "VEC3",
         "min": [-0.5, -0.5, -0.5], "max": [0.5, 0.5, 0.5]},
        {"bufferView": 1, "componentType": 5126, "count": nv, "type": "VEC3"},
        {"bufferView": 2, "componentType": 5123, "count": len(idx), "type": "SCALAR"},
        {"bufferView": 3, "componentType": 5126, "count": 2, "type": "SCALAR", "min": [0], "max": [1]},
        {"bufferView": 4, "componentType": 5126, "count": 2, "type": "VEC3"},
        {"bufferView": 5, "componentType": 5126, "count": 2, "type": "VEC4"}],
    "animations": [{"name": "slide", "samplers": [
        {"input": 3, "output": 4, "interpolation": "LINEAR"},
        {"input": 3, "output": 5, "interpolation": "LINEAR"}],
        "channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}},
                     {"sampler": 1, "target": {"node": 1, "path": "rotation"}}]}],
}
with open("animated_box.gltf", "w") as f:
    json.dump(doc, f, indent=1)
    f.write("\n")
