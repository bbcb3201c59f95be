#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Regenerates the small generated seed corpora in fuzz/corpus/<target>/ (deterministic).

Seeds derived from real files (the bundled scenes, baked .somm files) are made by fuzz/make_file_seeds.sh from a
built CLI. Run from the repository root: python3 fuzz/make_seeds.py
"""
import os
import random
import struct

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus")


def put(target, name, data):
    d = os.path.join(ROOT, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data if isinstance(data, bytes) else data.encode())


def f32(x):
    return struct.pack("<f", x)


rng = random.Random(6)

# fuzz_bird: level byte, then (u, v) float pairs: edges, vertices, NaN/inf, -0, denormals, just outside the triangle.
specials = [0.0, -0.0, 1.0, 0.5, 0.25, 1.0 / 3.0, float("inf"), float("-inf"), float("nan"), 1e-45, -1e-45,
            0.99999994, 1.0000001, 2.0, -1.0, 0.7, 0.3]
for level in (0, 1, 2, 5, 9, 12):
    pairs = b"".join(f32(a) + f32(b) for a in specials for b in specials[:4])
    put("fuzz_bird", f"specials_l{level}", bytes([level]) + pairs[: 8 * 67])
for level in (3, 8, 12):
    pairs = b"".join(f32(rng.uniform(-0.1, 1.1)) + f32(rng.uniform(-0.1, 1.1)) for _ in range(40))
    put("fuzz_bird", f"random_l{level}", bytes([level]) + pairs)
put("fuzz_bird", "snan", bytes([7]) + struct.pack("<II", 0x7F800001, 0xFFBFFFFF) * 3)

# fuzz_text_input: what `somm index` / `microtri` / `query` read.
put("fuzz_text_input", "index", "0.5 0.25\n0.25 0.5\n\n0.7   0.7\r\n0x1p-1 0x1p-2\ninf nan\n")
put("fuzz_text_input", "microtri", "0\n1\n15\n16777215\n18446744073709551615\n18446744073709551616\n")
put("fuzz_text_input", "malformed", "0.1 zebra\n0.1\n0.1 0.2 0.3\n0.1f 0.2\n-0 +1e-50\n1e39 -1e39\n\t\v\f 3 4\r")
put("fuzz_text_input", "random", "".join(f"{rng.uniform(-0.2, 1.2):.9g} {rng.uniform(-0.2, 1.2):.9g}\n"
                                         for _ in range(50)))

# fuzz_micromap: [head: level%7, fill bits 3-4, 4-state bit 7][op count][ops: u32 index, u8 state]...
def micromap_seed(maps):
    out = b""
    for level, four, fill, ops in maps:
        out += bytes([level | (fill << 3) | (0x80 if four else 0), len(ops)])
        for i, s in ops:
            out += struct.pack("<IB", i, s)
    return out


put("fuzz_micromap", "uniform", micromap_seed([(l, f, s, []) for l in range(4) for f in (0, 1) for s in range(4)]))
put("fuzz_micromap", "dedupe", micromap_seed([(3, 1, 0, [(5, 1), (9, 3)])] * 3 + [(3, 0, 0, [(5, 1)])] * 2))
put("fuzz_micromap", "random", micromap_seed([(rng.randrange(7), rng.randrange(2), rng.randrange(4),
                                               [(rng.randrange(4096), rng.randrange(4)) for _ in range(10)])
                                              for _ in range(12)]))

# ---- scene inputs (the fuzz targets' scratch directory also holds t.png, a 4x4 RGBA PNG, and b.bin, 64 bytes) ----
import base64
import json
import zlib


def png(w, h, color_type, depth, pixel):
    def chunk(t, d):
        return struct.pack(">I", len(d)) + t + d + struct.pack(">I", zlib.crc32(t + d) & 0xFFFFFFFF)
    raw = b"".join(b"\0" + b"".join(pixel(x, y) for x in range(w)) for y in range(h))
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, depth, color_type, 0, 0, 0)) +
            chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))


put("fuzz_image", "rgba16.png", png(3, 3, 6, 16, lambda x, y: struct.pack(">HHHH", x * 20000, y * 20000, 7, x * y * 9000)))
put("fuzz_image", "rgba8.png", png(4, 4, 6, 8, lambda x, y: bytes([x * 60, y * 60, 128, 255 if (x + y) % 2 else 0])))
put("fuzz_image", "rgb8.png", png(5, 2, 2, 8, lambda x, y: bytes([x * 50, y * 100, 3])))
put("fuzz_image", "huge_claim.png", png(1, 1, 6, 8, lambda x, y: b"\1\2\3\4").replace(
    struct.pack(">II", 1, 1), struct.pack(">II", 30000, 30000), 1))

# OBJ (+ NUL + MTL).
quad_obj = """# quad with a masked material
mtllib m.mtl
o leaf
v 0 0 0
v 1 0 0
v 1 1 0
v 0 1 0
vt 0 0
vt 1 0
vt 1 1
vt 0 1
vn 0 0 1
usemtl leafmat
f 1/1/1 2/2/1 3/3/1 4/4/1
usemtl bark
f -4/-4 -3/-3 -2/-2
g second
usemtl leafmat
f 1/1 3/3 4/4
"""
mtl = """newmtl leafmat
Kd 1 1 1
map_d -imfchan m t.png
newmtl bark
map_Kd -clamp on t.png
"""
put("fuzz_obj", "quad", quad_obj + "\0" + mtl)
put("fuzz_obj", "no_mtl", "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\nl 1 2\np 1\n")
put("fuzz_obj", "missing_texture", quad_obj + "\0" + "newmtl leafmat\nmap_d missing.png\nnewmtl bark\nmap_Kd t.png\n")
put("fuzz_obj", "bad_values", "v nan 0 0\nv inf 1 0\nv 0 1 1e40\nvt nan inf\nvt 0 0\nvt 1 1\nf 1/1 2/2 3/3\nf 1/5 2/2 9/3\n")


def gltf_doc(buffer_uri, image):
    pos = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    uv = struct.pack("<6f", 0, 0, 1, 0, 0, 1)
    idx = struct.pack("<3H", 0, 1, 2) + b"\0\0"
    data = pos + uv + idx
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "translation": [1, 2, 3], "children": [1]}, {"mesh": 0, "scale": [2, 2, 2]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "indices": 2, "material": 0},
                                   {"attributes": {"POSITION": 0, "TEXCOORD_0": 1}, "mode": 1}]}],
        "materials": [{"alphaMode": "MASK", "alphaCutoff": 0.4,
                       "pbrMetallicRoughness": {"baseColorTexture": {"index": 0, "texCoord": 0},
                                                "baseColorFactor": [1, 1, 1, 0.9]}}],
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9728, "wrapS": 33071, "wrapT": 33648}],
        "images": [image],
        "buffers": [{"byteLength": len(data), "uri": buffer_uri or
                     "data:application/octet-stream;base64," + base64.b64encode(data).decode()}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
                        {"buffer": 0, "byteOffset": len(pos), "byteLength": len(uv)},
                        {"buffer": 0, "byteOffset": len(pos) + len(uv), "byteLength": 6}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]},
                      {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC2"},
                      {"bufferView": 2, "componentType": 5123, "count": 3, "type": "SCALAR"}],
    }
    return doc, data


tiny_png = png(4, 4, 6, 8, lambda x, y: bytes([x * 60, y * 60, 128, 255 if (x + y) % 2 else 0]))
doc, _ = gltf_doc(None, {"uri": "t.png"})
put("fuzz_gltf", "datauri_external_image", b"\0" + json.dumps(doc).encode())
doc, _ = gltf_doc(None, {"uri": "data:image/png;base64," + base64.b64encode(tiny_png).decode()})
put("fuzz_gltf", "datauri_image", b"\0" + json.dumps(doc).encode())
doc, _ = gltf_doc("b.bin", {"uri": "missing.png"})
put("fuzz_gltf", "external_buffer_missing_image", b"\0" + json.dumps(doc).encode())
# GLB: the buffer and the image in the BIN chunk.
doc, data = gltf_doc(None, {"bufferView": 3, "mimeType": "image/png"})
image_at = len(data)
data = data + tiny_png
data += b"\0" * (-len(data) % 4)
doc["buffers"] = [{"byteLength": len(data)}]
doc["bufferViews"].append({"buffer": 0, "byteOffset": image_at, "byteLength": len(tiny_png)})
js = json.dumps(doc).encode()
js += b" " * (-len(js) % 4)
glb = (struct.pack("<III", 0x46546C67, 2, 12 + 8 + len(js) + 8 + len(data)) + struct.pack("<II", len(js), 0x4E4F534A) +
       js + struct.pack("<II", len(data), 0x004E4942) + data)
put("fuzz_gltf", "glb", b"\1" + glb)
# The bundled oak tree's glTF JSON (its .bin is not in the scratch directory: exercises the error paths).
oak = os.path.join(os.path.dirname(ROOT), "..", "data", "oak-tree", "oaktree.gltf")
if os.path.exists(oak):
    put("fuzz_gltf", "oaktree_json", b"\0" + open(oak, "rb").read())

# fuzz_encode: mode byte (0 parse an EncodedArray, 1 validate one map blob, 2 build from micromap scripts). Serialised
# arrays for mode 0 are written by fuzz/make_file_seeds.sh from a built tree. The version-7 sdag arrays
# (array_sdag_v7_*: the local-leaves worked example, records with agreeing and disagreeing uniform children, random
# 2- and 4-state arrays of levels 5..8 with shared subtrees) were serialized by the library of that version; the
# older array_* seeds (array_sdag_v6_* and before) stay as inputs the parser refuses. array_sdag_v8_leaf_transforms is
# docs/encodings.md's worked example with leaf transforms (version 8), serialized by the library.
for k in range(4):
    put("fuzz_encode", f"build_{k}", bytes([2]) + bytes(rng.randrange(256) for _ in range(60 + 40 * k)))
put("fuzz_encode", "build_uniform", bytes([2]) + bytes([3, 0, 0x83, 0, 0x8B, 1, 200, 1, 0, 5, 2, 7, 3]))
for kind in range(3):
    for level in (0, 1, 3, 5):
        put("fuzz_encode", f"map_k{kind}_l{level}", bytes([1, kind | (level << 2), level & 1]) +
            bytes(rng.randrange(256) for _ in range(8 + 4 ** level // 2)))
# Build scripts whose maps (head bit 0x40) are added twice, the second time with a run of states changed: subtrees
# for csm / sdag to share (levels 3..6, both formats). Own generator, so that the seeds above stay as they were.
dag_rng = random.Random(1234)
for k in range(3):
    seed = b""
    for t in range(6):
        seed += bytes([0x40 | (3 + (t + k) % 4) | (0x80 if t % 2 else 0), 6])
        seed += bytes(dag_rng.randrange(256) for _ in range(3 * 6))
        seed += bytes([dag_rng.randrange(256), dag_rng.randrange(256)] + [dag_rng.randrange(256) for _ in range(16)])
    put("fuzz_encode", f"build_dag_{k}", bytes([2]) + seed)

# Six level-3 4-state maps (head 0x81, runs (10, opaque), (5, unknown-opaque)), then 480 triangles (count byte 60),
# every 7th a map, the others opaque (state byte 0x1d): a long array whose sdag index buffer is rank-packed.
put("fuzz_encode", "build_rank_index", bytes([2]) + bytes([0x81, 2, 10, 1, 0, 5, 3, 0]) * 6 + bytes([60, 0x1D]))

# fuzz_somm_file: version-2 .somm files (docs/somm-format.md) written here, checksums from the system libxxhash. The
# version-1 seeds (v1_*) were written by the version-1 library and are kept as they are.
import ctypes
import ctypes.util

_xxh = ctypes.CDLL(ctypes.util.find_library("xxhash") or "libxxhash.so.0")
_xxh.XXH3_64bits.restype = ctypes.c_uint64
_xxh.XXH3_64bits.argtypes = [ctypes.c_char_p, ctypes.c_size_t]
_xxh.XXH3_64bits_withSeed.restype = ctypes.c_uint64
_xxh.XXH3_64bits_withSeed.argtypes = [ctypes.c_char_p, ctypes.c_size_t, ctypes.c_uint64]


def somm_string(s):
    return struct.pack("<I", len(s)) + s.encode()


def somm_chunk(ctype, index, payload):
    head = ctype.encode() + struct.pack("<IQ", index, len(payload))
    check = _xxh.XXH3_64bits_withSeed(payload, len(payload), _xxh.XXH3_64bits(head, 16))
    out = head + struct.pack("<Q", check) + payload
    return out + b"\0" * (-len(out) % 8)


def somm_array(maps, indices):
    """maps: list of (level, format 1|2, data bytes); indices: per triangle a map number or -1..-4."""
    data = b""
    desc = b""
    for level, fmt, blob in maps:
        desc += struct.pack("<IHH", len(data), level, fmt)
        data += blob
    hist = {}
    for level, fmt, _ in maps:
        hist[(fmt, level)] = hist.get((fmt, level), 0) + 1
    tri = {}
    for i in indices:
        if i >= 0:
            key = (maps[i][1], maps[i][0])
            tri[key] = tri.get(key, 0) + 1
    wide = len(maps) > 0xFFFB
    out = struct.pack("<IIIIIIQ", len(indices), len(maps), 4 if wide else 2, len(hist), len(tri), 0, len(data)) + desc
    for h in (hist, tri):
        for (fmt, level) in sorted(h):
            out += struct.pack("<III", h[(fmt, level)], level, fmt)
    for i in indices:
        out += struct.pack("<I" if wide else "<H", i & (0xFFFFFFFF if wide else 0xFFFF))
    return out + data


def somm_v2(geometries, arrays, encodings):
    """geometries: (name, triangles, array, first, format, minLevel, maxLevel); arrays: FLAT payloads;
    encodings: per array a list of (id, bytes)."""
    meta = struct.pack("<II", len(geometries), len(arrays)) + somm_string("seed.gltf") + somm_string("somm seeds")
    meta += struct.pack("<I", 2) + somm_string("level") + somm_string("2") + somm_string("arrays") + somm_string("scene")
    body = somm_chunk("META", 0xFFFFFFFF, meta)
    for g, (name, tris, array, first, fmt, lo, hi) in enumerate(geometries):
        p = somm_string(name) + somm_string(name + "-mat") + struct.pack("<III", tris, array, first)
        p += bytes([fmt, lo, hi, 1, 0, 0, 0, 0]) + f32(0.5) + struct.pack("<IQQQ", 0, tris * 16, tris * 3, 0)
        body += somm_chunk("GEOM", g, p)
    for a, flat in enumerate(arrays):
        body += somm_chunk("FLAT", a, flat)
        for eid, blob in encodings[a]:
            body += somm_chunk("ENCD", a, eid.encode() + struct.pack("<I", 0) + blob)
    body += somm_chunk("END ", 0xFFFFFFFF, b"")
    size = 32 + len(body)
    head = b"SOMM\r\n\x1a\n" + struct.pack("<IIQ", 2, 0, size)
    return head + struct.pack("<Q", _xxh.XXH3_64bits(head, 24)) + body


def random_map(level, fmt):
    n = max(1, (4 ** level * (2 if fmt == 2 else 1) + 7) // 8)
    return (level, fmt, bytes(rng.randrange(256) for _ in range(n)))


# One scene-wide array shared by a 4-state and a 2-state geometry (with special indices), plus an empty geometry.
maps = [random_map(2, 2), random_map(1, 2), random_map(2, 1), random_map(0, 2)]
idx = [0, 1, -2, 0, 3, -1, 1] + [2, -1, 2, -2]
put("fuzz_somm_file", "v2_scene_array", somm_v2(
    [("leaves", 7, 0, 0, 2, 0, 2), ("bark", 4, 0, 7, 1, 2, 2), ("empty", 0, 0, 11, 2, 0, 0)],
    [somm_array(maps, idx)], [[("dfs ", bytes(range(9))), ("rank", b"")]]))
# One array per geometry, as `somm bake --arrays geometry` writes.
put("fuzz_somm_file", "v2_per_geometry", somm_v2(
    [("a", 3, 0, 0, 2, 1, 1), ("b", 2, 1, 0, 1, 2, 2)],
    [somm_array([random_map(1, 2), random_map(1, 2)], [0, 1, -3]), somm_array([random_map(2, 1)], [0, 0])],
    [[("hybr", bytes(13))], []]))
put("fuzz_somm_file", "v2_empty", somm_v2([], [], []))
