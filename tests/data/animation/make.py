#!/usr/bin/env python3
"""Writes the animation test files (tests/animation.rs): `animated.gltf` and,
in ../bad_scenes, one copy per malformed-animation case. Rerun after editing."""
import base64, json, math, os, struct

HERE = os.path.dirname(os.path.abspath(__file__))
BAD = os.path.join(HERE, "..", "bad_scenes")


def build(times0=(0.0, 1.0, 2.0), trans_count=3, path0="translation", nan_key=False):
    blob = bytearray()
    views, accessors = [], []

    def add(data, count, typ, minmax=None):
        while len(blob) % 4:
            blob.append(0)
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)})
        blob.extend(data)
        a = {"bufferView": len(views) - 1, "componentType": 5126, "count": count, "type": typ}
        if minmax:
            a["min"], a["max"] = minmax
        accessors.append(a)
        return len(accessors) - 1

    pos = add(struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0), 3, "VEC3", ([0, 0, 0], [1, 1, 0]))
    while len(blob) % 4:
        blob.append(0)
    views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": 6})
    blob.extend(struct.pack("<3H", 0, 1, 2))
    accessors.append({"bufferView": len(views) - 1, "componentType": 5123, "count": 3, "type": "SCALAR"})
    idx = len(accessors) - 1
    t0 = list(times0)
    if nan_key:
        t0[1] = float("nan")
    in0 = add(struct.pack("<%df" % len(t0), *t0), len(t0), "SCALAR", ([0.0], [2.0]))
    tr = [(0, 0, 0), (1, 0, 0), (1, 2, 0)][:trans_count]
    out0 = add(struct.pack("<%df" % (3 * len(tr)), *[c for v in tr for c in v]), len(tr), "VEC3")
    in1 = add(struct.pack("<2f", 0.0, 2.0), 2, "SCALAR", ([0.0], [2.0]))
    s = math.sqrt(0.5)
    out1 = add(struct.pack("<8f", 0, 0, 0, 1, 0, 0, s, s), 2, "VEC4")
    in2 = add(struct.pack("<2f", 0.0, 1.0), 2, "SCALAR", ([0.0], [1.0]))
    out2 = add(struct.pack("<6f", 3, 0, 0, 3, 1, 0), 2, "VEC3")
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 2]}],
        "nodes": [
            {"name": "carrier", "children": [1]},
            {"name": "moving", "mesh": 0, "translation": [0, 0, -5]},
            {"name": "hopper", "mesh": 0, "translation": [3, 0, 0]},
        ],
        "meshes": [{"name": "triangle", "primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]}],
        "animations": [
            {
                "name": "slide",
                "channels": [
                    {"sampler": 0, "target": {"node": 0, "path": path0}},
                    {"sampler": 1, "target": {"node": 0, "path": "rotation"}},
                ],
                "samplers": [
                    {"input": in0, "output": out0, "interpolation": "LINEAR"},
                    {"input": in1, "output": out1, "interpolation": "LINEAR"},
                ],
            },
            {
                "name": "hop",
                "channels": [{"sampler": 0, "target": {"node": 2, "path": "translation"}}],
                "samplers": [{"input": in2, "output": out2, "interpolation": "STEP"}],
            },
        ],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [
            {
                "uri": "data:application/octet-stream;base64," + base64.b64encode(bytes(blob)).decode(),
                "byteLength": len(blob),
            }
        ],
    }
    return json.dumps(doc, indent=1)


def write(path, text):
    with open(path, "w") as f:
        f.write(text + "\n")


write(os.path.join(HERE, "animated.gltf"), build())
write(os.path.join(BAD, "anim_not_increasing.gltf"), build(times0=(0.0, 1.0, 1.0)))
write(os.path.join(BAD, "anim_count_mismatch.gltf"), build(trans_count=2))
write(os.path.join(BAD, "anim_unknown_path.gltf"), build(path0="colour"))
write(os.path.join(BAD, "anim_nan_key.gltf"), build(nan_key=True))
