#!/usr/bin/env python3
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
