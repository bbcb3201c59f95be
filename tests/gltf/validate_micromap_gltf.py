#!/usr/bin/env python3
# SPDX-License-Identifier: MIT
"""Independent validator of the Khronos draft EXT_mesh_opacity_micromap (glTF PR 2623) for .gltf/.glb files.

Written from the draft's text alone (it shares no code with somm's C++ reader). Checks every MUST of the draft plus
the glTF 2.0 core rules the extension relies on (bufferView/accessor bounds, extensionsUsed). With --strict, the
SHOULD NOT (listing the extension in extensionsRequired) is an error too, and the file must use the extension.

Usage: validate_micromap_gltf.py [--strict] [--expect-error TEXT] FILE...
Exit 0 when every file is valid (or, with --expect-error, when every file is rejected with a message containing
TEXT); prints one line per problem.
"""
import base64
import json
import os
import struct
import sys
import urllib.parse

EXT = "EXT_mesh_opacity_micromap"


class Invalid(Exception):
    pass


def load(path):
    with open(path, "rb") as f:
        raw = f.read()
    chunk = None
    if raw[:4] == b"glTF":
        magic, version, length = struct.unpack_from("<III", raw, 0)
        if version != 2 or length > len(raw):
            raise Invalid("bad GLB header")
        jlen, jtype = struct.unpack_from("<II", raw, 12)
        if jtype != 0x4E4F534A:
            raise Invalid("first GLB chunk is not JSON")
        doc = json.loads(raw[20:20 + jlen].decode("utf-8"))
        at = 20 + ((jlen + 3) & ~3)
        if at + 8 <= length:
            blen, btype = struct.unpack_from("<II", raw, at)
            if btype == 0x004E4942:
                chunk = raw[at + 8:at + 8 + blen]
    else:
        doc = json.loads(raw.decode("utf-8"))
    buffers = []
    for i, b in enumerate(doc.get("buffers", [])):
        n = b.get("byteLength")
        if not isinstance(n, int) or n < 1:
            raise Invalid(f"buffers[{i}]: byteLength must be an integer >= 1")
        uri = b.get("uri")
        if uri is None:
            if i != 0 or chunk is None:
                raise Invalid(f"buffers[{i}] has no uri and no GLB BIN chunk")
            data = chunk
        elif uri.startswith("data:"):
            data = base64.b64decode(uri.split(",", 1)[1])
        else:
            with open(os.path.join(os.path.dirname(path), urllib.parse.unquote(uri)), "rb") as f:
                data = f.read()
        if len(data) < n:
            raise Invalid(f"buffers[{i}] holds {len(data)} bytes < byteLength {n}")
        buffers.append(data[:n])
    return doc, buffers


def view_bytes(doc, buffers, index, what):
    views = doc.get("bufferViews", [])
    if not isinstance(index, int) or index < 0 or index >= len(views):
        raise Invalid(f"{what}: bufferView {index} does not exist")
    v = views[index]
    buf, off, n = v.get("buffer"), v.get("byteOffset", 0), v.get("byteLength")
    if not isinstance(buf, int) or buf < 0 or buf >= len(buffers):
        raise Invalid(f"bufferViews[{index}]: buffer {buf} does not exist")
    if not isinstance(n, int) or n < 1 or off < 0 or off + n > len(buffers[buf]):
        raise Invalid(f"bufferViews[{index}]: range outside buffer {buf}")
    return buffers[buf][off:off + n], v, off


def is_int(x):
    return isinstance(x, int) and not isinstance(x, bool)


def validate(path, strict):
    doc, buffers = load(path)
    root_ext = doc.get("extensions", {}).get(EXT)
    prim_exts = []
    for mi, mesh in enumerate(doc.get("meshes", [])):
        for pi, prim in enumerate(mesh.get("primitives", [])):
            e = prim.get("extensions", {}).get(EXT)
            if e is not None:
                prim_exts.append((mi, pi, prim, e))
    if root_ext is None and not prim_exts:
        if strict:
            raise Invalid(f"{EXT} is not used")
        return
    if EXT not in doc.get("extensionsUsed", []):
        raise Invalid(f"{EXT} is used but not listed in extensionsUsed")
    if strict and EXT in doc.get("extensionsRequired", []):
        raise Invalid(f"{EXT} SHOULD NOT be listed in extensionsRequired")
    micromaps = (root_ext or {}).get("micromaps")
    if not isinstance(micromaps, list):
        raise Invalid("root micromaps must be an array")
    records_per_map = []
    for i, m in enumerate(micromaps):
        w = f"micromaps[{i}]"
        for key in ("data", "triangles", "usageCounts", "usageLevels", "usageFormats"):
            if key not in m:
                raise Invalid(f"{w}: {key} is required")
        uc, ul, uf = m["usageCounts"], m["usageLevels"], m["usageFormats"]
        if not (len(uc) == len(ul) == len(uf)):
            raise Invalid(f"{w}: usage arrays must have the same length")
        if len(uc) < 1:
            raise Invalid(f"{w}: usage arrays must not be empty")
        for k in range(len(uc)):
            if not is_int(uc[k]) or uc[k] < 1:
                raise Invalid(f"{w}: usageCounts[{k}] must be >= 1")
            if not is_int(ul[k]) or not 0 <= ul[k] <= 12:
                raise Invalid(f"{w}: usageLevels[{k}] must be in [0, 12]")
            if uf[k] not in (1, 2):
                raise Invalid(f"{w}: usageFormats[{k}] must be 1 or 2")
        data, dview, _ = view_bytes(doc, buffers, m["data"], w + " data")
        tris, tview, _ = view_bytes(doc, buffers, m["triangles"], w + " triangles")
        if "byteStride" in dview or "byteStride" in tview:
            raise Invalid(f"{w}: data/triangles bufferViews must not define byteStride")
        if len(tris) % 8:
            raise Invalid(f"{w}: triangles byteLength must be a multiple of 8")
        pairs = {}
        regions = []
        for r in range(len(tris) // 8):
            off, level, fmt = struct.unpack_from("<IHH", tris, 8 * r)
            if level > 12:
                raise Invalid(f"{w}: record {r}: subdivisionLevel {level} not in [0, 12]")
            if fmt not in (1, 2):
                raise Invalid(f"{w}: record {r}: format {fmt} not 1 or 2")
            size = ((4 ** level) * (1 if fmt == 1 else 2) + 7) // 8
            if off + size > len(data):
                raise Invalid(f"{w}: record {r}: region outside data")
            regions.append((off, off + size, r))
            pairs[(level, fmt)] = pairs.get((level, fmt), 0) + 1
        usage = {}
        for k in range(len(uc)):
            usage[(ul[k], uf[k])] = usage.get((ul[k], uf[k]), 0) + uc[k]
        if usage != pairs:
            raise Invalid(f"{w}: usage entries {sorted(usage.items())} do not match the records {sorted(pairs.items())}")
        regions.sort()
        for a, b in zip(regions, regions[1:]):
            if b[0] < a[1]:
                raise Invalid(f"{w}: regions of records {a[2]} and {b[2]} overlap")
        records_per_map.append(len(tris) // 8)
    accessors = doc.get("accessors", [])
    sizes = {5121: 1, 5123: 2, 5125: 4, 5122: 2, 5124: 4}
    for mi, pi, prim, e in prim_exts:
        w = f"meshes[{mi}].primitives[{pi}]"
        if prim.get("mode", 4) != 4:
            raise Invalid(f"{w}: mode must be 4")
        mm = e.get("micromap")
        if not is_int(mm) or not 0 <= mm < len(micromaps):
            raise Invalid(f"{w}: micromap {mm} is not a root micromaps index")
        base = e.get("micromapBaseTriangle", 0)
        if not is_int(base) or base < 0:
            raise Invalid(f"{w}: micromapBaseTriangle must be an integer >= 0")
        if "indices" in prim:
            ntri = accessors[prim["indices"]]["count"] // 3
        else:
            ntri = accessors[prim["attributes"]["POSITION"]]["count"] // 3
        if "micromapIndices" in e:
            ai = e["micromapIndices"]
            if not is_int(ai) or not 0 <= ai < len(accessors):
                raise Invalid(f"{w}: micromapIndices {ai} is not an accessor")
            a = accessors[ai]
            if a.get("type") != "SCALAR":
                raise Invalid(f"{w}: micromapIndices type must be SCALAR")
            ct = a.get("componentType")
            if ct not in sizes:
                raise Invalid(f"{w}: micromapIndices componentType {ct} not allowed")
            if a.get("normalized") is True:
                raise Invalid(f"{w}: micromapIndices must not be normalized")
            if a.get("count") != ntri:
                raise Invalid(f"{w}: micromapIndices count {a.get('count')} != triangle count {ntri}")
            size = sizes[ct]
            if "bufferView" in a:
                vb, v, voff = view_bytes(doc, buffers, a["bufferView"], w + " micromapIndices")
                if "byteStride" in v:
                    raise Invalid(f"{w}: micromapIndices bufferView must not define byteStride")
                aoff = a.get("byteOffset", 0)
                if (voff + aoff) % size:
                    raise Invalid(f"{w}: micromapIndices not aligned to its component size")
                if aoff + ntri * size > len(vb):
                    raise Invalid(f"{w}: micromapIndices elements outside their bufferView")
                fmt = {5121: "B", 5123: "H", 5125: "I", 5122: "h", 5124: "i"}[ct]
                values = list(struct.unpack_from("<" + fmt * ntri, vb, aoff))
            else:
                values = [0] * ntri
            bits = size * 8
            lookups = []
            for t, v in enumerate(values):
                if ct in (5122, 5124):
                    if v < -4:
                        raise Invalid(f"{w}: micromapIndices element {t} = {v} < -4")
                    lookups.append(v)
                else:
                    lookups.append(v - (1 << bits) if v >= (1 << bits) - 4 else v)
        else:
            lookups = list(range(ntri))
        for t, v in enumerate(lookups):
            if v >= 0 and v + base >= records_per_map[mm]:
                raise Invalid(f"{w}: triangle {t} uses record {v + base} >= {records_per_map[mm]} records")


def main(argv):
    strict = "--strict" in argv
    argv = [a for a in argv if a != "--strict"]
    expect = None
    if "--expect-error" in argv:
        k = argv.index("--expect-error")
        expect = argv[k + 1]
        argv = argv[:k] + argv[k + 2:]
    bad = 0
    for path in argv:
        try:
            validate(path, strict)
            if expect is not None:
                print(f"{path}: accepted, expected an error containing '{expect}'")
                bad += 1
            else:
                print(f"{path}: valid {EXT}")
        except (Invalid, KeyError, IndexError, TypeError, ValueError, OSError, struct.error) as e:
            if expect is not None and expect in str(e):
                print(f"{path}: rejected as expected: {e}")
            else:
                print(f"{path}: INVALID: {e}")
                bad += 1
    return 1 if bad or not argv else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
