#!/usr/bin/env python3
"""Writes voxkit's conformance corpus for MagicaVoxel .vox scenes and glTF 2.0
extensions (tests/data/formats/{vox,gltf}/) and the answers (vox_gltf_expected.json).

Standard library only. The answers come from the geometry each file encodes,
computed here independently of voxkit's readers:

- .vox: world voxels by MagicaVoxel's placement as ogt_vox and vengi apply it
  (voxel l of a model of size s is the cube centred at l + 1/2 - floor(s/2) in
  model space; world cell = floor(R (l + 1/2 - floor(s/2))) + t, R the _r
  matrix, row-major, applied to column vectors; nTRN frames compose from the
  root down), with float matrices, not voxkit's integer offsets;
- glTF: the positions before quantization or compression (dequantized by the
  spec's formulas), transformed by the node's TRS.

Run from the repository root: python3 tests/data/formats/make_vox_gltf.py
"""
import base64
import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))


# ---------------------------------------------------------------- .vox writer

def chunk(cid, content=b"", children=b""):
    return cid + struct.pack("<ii", len(content), len(children)) + content + children


def i32(v):
    return struct.pack("<i", v)


def sdict(d):
    out = i32(len(d))
    for k, v in d.items():
        kb, vb = k.encode(), str(v).encode()
        out += i32(len(kb)) + kb + i32(len(vb)) + vb
    return out


class Vox:
    def __init__(self):
        self.models = []  # (size, [(x, y, z, c)])
        self.nodes = {}   # id -> chunk bytes (written in id order)
        self.layers = []  # attrs dicts
        self.tree = {}    # id -> ("T", attrs, child, layer, frames) | ("G", kids) | ("S", [(m, attrs)])

    def model(self, size, voxels):
        self.models.append((size, voxels))
        return len(self.models) - 1

    def trn(self, nid, child, t=None, r=None, layer=-1, attrs=None, frames=None):
        if frames is None:
            f = {}
            if t is not None:
                f["_t"] = "%d %d %d" % t
            if r is not None:
                f["_r"] = str(r)
            frames = [f]
        self.tree[nid] = ("T", attrs or {}, child, layer, frames)

    def grp(self, nid, kids):
        self.tree[nid] = ("G", kids)

    def shp(self, nid, models):
        self.tree[nid] = ("S", [m if isinstance(m, tuple) else (m, {}) for m in models])

    def bytes(self):
        body = b""
        for size, vox in self.models:
            body += chunk(b"SIZE", b"".join(i32(v) for v in size))
            body += chunk(b"XYZI", i32(len(vox)) + b"".join(bytes(v) for v in vox))
        for nid in sorted(self.tree):
            n = self.tree[nid]
            if n[0] == "T":
                _, attrs, child, layer, frames = n
                c = i32(nid) + sdict(attrs) + i32(child) + i32(-1) + i32(layer) + i32(len(frames))
                c += b"".join(sdict(f) for f in frames)
                body += chunk(b"nTRN", c)
            elif n[0] == "G":
                body += chunk(b"nGRP", i32(nid) + sdict({}) + i32(len(n[1])) + b"".join(i32(k) for k in n[1]))
            else:
                c = i32(nid) + sdict({}) + i32(len(n[1]))
                c += b"".join(i32(m) + sdict(a) for m, a in n[1])
                body += chunk(b"nSHP", c)
        for i, attrs in enumerate(self.layers):
            body += chunk(b"LAYR", i32(i) + sdict(attrs) + i32(-1))
        return b"VOX " + i32(150) + chunk(b"MAIN", b"", body)

    # -- the reference placement (independent of voxkit) --
    def world(self):
        if not self.tree:
            size, vox = self.models[0]
            return sorted({(x, y, z) for x, y, z, _ in vox})
        out = set()
        ident = ([[1, 0, 0], [0, 1, 0], [0, 0, 1]], [0.0, 0.0, 0.0])

        def first_frame(frames):
            return min(frames, key=lambda f: int(f.get("_f", 0))) if frames else {}

        def walk(nid, M):
            n = self.tree[nid]
            if n[0] == "T":
                _, attrs, child, layer, frames = n
                if attrs.get("_hidden") == "1":
                    return
                if 0 <= layer < len(self.layers) and self.layers[layer].get("_hidden") == "1":
                    return
                f = first_frame(frames)
                R = rot_matrix(int(f.get("_r", 4)))
                t = [float(v) for v in f.get("_t", "0 0 0").split()]
                # M ∘ (R, t)
                R0, t0 = M
                R1 = [[sum(R0[i][k] * R[k][j] for k in range(3)) for j in range(3)] for i in range(3)]
                t1 = [sum(R0[i][k] * t[k] for k in range(3)) + t0[i] for i in range(3)]
                walk(child, (R1, t1))
            elif n[0] == "G":
                for k in n[1]:
                    walk(k, M)
            else:
                m, _ = min(n[1], key=lambda ma: int(ma[1].get("_f", 0)))
                size, vox = self.models[m]
                R, t = M
                for x, y, z, _ in vox:
                    c = [x + 0.5 - size[0] // 2, y + 0.5 - size[1] // 2, z + 0.5 - size[2] // 2]
                    w = [sum(R[i][k] * c[k] for k in range(3)) + t[i] for i in range(3)]
                    out.add(tuple(math.floor(v) for v in w))

        walk(0, ident)
        return sorted(out)


def rot_matrix(b):
    """The _r byte as a row-major matrix (MagicaVoxel-file-format-vox-extension.txt)."""
    a0, a1 = b & 3, (b >> 2) & 3
    a2 = 3 - a0 - a1
    R = [[0] * 3 for _ in range(3)]
    for row, (a, bit) in enumerate(zip((a0, a1, a2), (4, 5, 6))):
        R[row][a] = -1 if (b >> bit) & 1 else 1
    return R


def all_rotation_bytes():
    out = []
    for a0 in range(3):
        for a1 in range(3):
            if a0 != a1:
                for s in range(8):
                    out.append(a0 | (a1 << 2) | (s << 4))
    return out


def asymmetric_model(size):
    """A voxel on each axis end and a few in between, so every signed
    permutation gives a different shape."""
    sx, sy, sz = size
    pts = {(0, 0, 0), (sx - 1, 0, 0), (0, sy - 1, 0), (0, 0, sz - 1), (sx - 1, sy - 1, sz - 1),
           (sx // 2, sy // 2, sz // 2), (1 % sx, 0, sz - 1)}
    return [(x, y, z, 1 + (x + y + z) % 200) for x, y, z in sorted(pts)]


def vox_files():
    files = {}
    # Each of the 48 signed permutations (24 rotations and their mirrors),
    # one instance each, odd and even model sizes.
    for tag, size in (("odd", (3, 5, 7)), ("even", (4, 2, 6))):
        v = Vox()
        m = v.model(size, asymmetric_model(size))
        rots = all_rotation_bytes()
        kids = []
        for i, r in enumerate(rots):
            tid, sid = 2 + 2 * i, 3 + 2 * i
            v.trn(tid, sid, t=(20 * (i % 8), 20 * (i // 8), -3), r=r, layer=0)
            v.shp(sid, [m])
            kids.append(tid)
        v.trn(0, 1)
        v.grp(1, kids)
        v.layers.append({})
        files["rotations_%s.vox" % tag] = (v, [])
    # Instancing: one model, three shape nodes.
    v = Vox()
    m = v.model((3, 2, 2), asymmetric_model((3, 2, 2)))
    v.trn(0, 1)
    v.grp(1, [2, 4, 6])
    for i, (tid, t) in enumerate(((2, (0, 0, 0)), (4, (10, 0, 0)), (6, (0, 7, 5)))):
        v.trn(tid, tid + 1, t=t, r=[4, 22, 113][i], layer=0)
        v.shp(tid + 1, [m])
    v.layers.append({})
    files["instanced.vox"] = (v, [])
    # Nested groups with rotations and translations at every level.
    v = Vox()
    a = v.model((5, 3, 1), asymmetric_model((5, 3, 1)))
    b = v.model((2, 2, 4), asymmetric_model((2, 2, 4)))
    v.trn(0, 1)
    v.grp(1, [2, 8])
    v.trn(2, 3, t=(4, -6, 1), r=17)       # group transform
    v.grp(3, [4, 6])
    v.trn(4, 5, t=(1, 2, 3), r=40)
    v.shp(5, [a])
    v.trn(6, 7, t=(-3, 0, 2))
    v.grp(7, [10])
    v.trn(10, 11, t=(0, 5, -2), r=98)     # a third level
    v.shp(11, [b])
    v.trn(8, 9, t=(30, 0, 0), r=6)
    v.shp(9, [a])
    v.layers.append({})
    files["groups.vox"] = (v, [])
    # Hidden layer and hidden node: skipped, with warnings.
    v = Vox()
    a = v.model((2, 2, 2), asymmetric_model((2, 2, 2)))
    v.trn(0, 1)
    v.grp(1, [2, 4, 6])
    v.trn(2, 3, t=(0, 0, 0), layer=0)
    v.shp(3, [a])
    v.trn(4, 5, t=(10, 0, 0), layer=1)
    v.shp(5, [a])
    v.trn(6, 7, t=(20, 0, 0), layer=0, attrs={"_hidden": "1", "_name": "ghost"})
    v.shp(7, [a])
    v.layers += [{"_name": "shown"}, {"_name": "backdrop", "_hidden": "1"}]
    files["hidden.vox"] = (v, ["hidden layer 1", "hidden node 6"])
    # The 0.98 layout: several models, no scene graph = animation frames.
    v = Vox()
    v.model((3, 3, 3), asymmetric_model((3, 3, 3)))
    v.model((3, 3, 3), [(1, 1, 1, 5)])
    v.model((4, 4, 4), [(3, 3, 3, 5)])
    files["animation_frames.vox"] = (v, ["animation frames"])
    # Keyframes: an nTRN with frames out of order and an nSHP with models.
    v = Vox()
    a = v.model((3, 1, 1), asymmetric_model((3, 1, 1)))
    b = v.model((1, 1, 2), asymmetric_model((1, 1, 2)))
    v.trn(0, 1)
    v.grp(1, [2])
    v.trn(2, 3, layer=0, frames=[{"_f": "10", "_t": "50 50 50"}, {"_f": "0", "_t": "1 2 3", "_r": "24"},
                                 {"_f": "20", "_t": "9 9 9"}])
    v.shp(3, [(b, {"_f": "5"}), (a, {"_f": "0"})])
    v.layers.append({})
    files["keyframes.vox"] = (v, ["animated transforms in node 2", "animated shapes in node 3"])
    return files


# ---------------------------------------------------------------- glTF writer

def data_uri(b):
    return "data:application/octet-stream;base64," + base64.b64encode(b).decode()


TETRA = [(0, 1, 2), (0, 1, 3), (0, 2, 3), (1, 2, 3)]
CT = {"i8": (5120, "b", 1, 127), "u8": (5121, "B", 1, 255), "i16": (5122, "h", 2, 32767),
      "u16": (5123, "H", 2, 65535), "f32": (5126, "f", 4, None)}


def pack_vec3(kind, pts, stride):
    _, fmt, size, _ = CT[kind]
    out = b""
    for p in pts:
        e = struct.pack("<3" + fmt, *p)
        out += e + b"\0" * (stride - len(e))
    return out


def trs(node, p):
    s = node.get("scale", [1, 1, 1])
    t = node.get("translation", [0, 0, 0])
    return [p[i] * s[i] + t[i] for i in range(3)]


def gltf_doc(accessors, views, buffers, node, extra=None, indices=None):
    prim = {"attributes": {"POSITION": 0}}
    if indices is not None:
        prim["indices"] = indices
    d = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [node],
         "meshes": [{"primitives": [prim]}], "accessors": accessors, "bufferViews": views,
         "buffers": buffers}
    d.update(extra or {})
    return d


def minmax(pts):
    return [min(p[i] for p in pts) for i in range(3)], [max(p[i] for p in pts) for i in range(3)]


def quantized(kind, normalized):
    ct, fmt, size, qmax = CT[kind]
    signed = kind.startswith("i")
    q = [(-qmax - 1 if signed else 0, 0, 0), (qmax, 0, 0), (0, qmax, 0), (1, 2, qmax)]
    stride = 4 if size == 1 else 8  # 4-byte aligned vertices, as exporters write them
    pos = pack_vec3(kind, q, stride)
    idx = struct.pack("<12H", *[i for t in TETRA for i in t])
    blob = pos + idx
    acc = [{"bufferView": 0, "componentType": ct, "count": 4, "type": "VEC3", "normalized": normalized,
            "min": minmax(q)[0], "max": minmax(q)[1]},
           {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}]
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos), "byteStride": stride, "target": 34962},
             {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx), "target": 34963}]
    # The node scale that dequantizes (gltfpack style): to unit size.
    s = 2.0 if normalized else 1.0 / qmax
    node = {"mesh": 0, "scale": [s, s, s], "translation": [0.5, -1.0, 2.0]}

    def deq(c):
        if not normalized:
            return float(c)
        return max(c / qmax, -1.0)

    want = [trs(node, [deq(c) for c in p]) for p in q]
    doc = gltf_doc(acc, views, [{"byteLength": len(blob), "uri": data_uri(blob)}], node,
                   {"extensionsUsed": ["KHR_mesh_quantization"],
                    "extensionsRequired": ["KHR_mesh_quantization"]}, indices=1)
    return doc, want


def sparse(base):
    # A quad (two triangles); sparse values replace vertices 2 and 3.
    base_pts = [(0, 0, 0), (1, 0, 0), (1, 1, 0), (0, 1, 0)]
    sp_idx = [2, 3]
    sp_val = [(3.0, 2.0, 0.5), (-1.0, 4.0, 0.25)]
    bb = pack_vec3("f32", base_pts, 12)
    si = struct.pack("<2B", *sp_idx) + b"\0\0"
    sv = pack_vec3("f32", sp_val, 12)
    idx = struct.pack("<6H", 0, 1, 2, 0, 2, 3)
    blob = bb + si + sv + idx
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": 48},
             {"buffer": 0, "byteOffset": 48, "byteLength": 2},
             {"buffer": 0, "byteOffset": 52, "byteLength": 24},
             {"buffer": 0, "byteOffset": 76, "byteLength": 12}]
    pts = [list(p) for p in (base_pts if base else [(0, 0, 0)] * 4)]
    for i, v in zip(sp_idx, sp_val):
        pts[i] = list(v)
    acc = {"componentType": 5126, "count": 4, "type": "VEC3", "min": minmax(pts)[0], "max": minmax(pts)[1],
           "sparse": {"count": 2, "indices": {"bufferView": 1, "componentType": 5121},
                      "values": {"bufferView": 2}}}
    if base:
        acc["bufferView"] = 0
    node = {"mesh": 0, "translation": [0, 0, 1]}
    doc = gltf_doc([acc, {"bufferView": 3, "componentType": 5123, "count": 6, "type": "SCALAR"}], views,
                   [{"byteLength": len(blob), "uri": data_uri(blob)}], node, indices=1)
    return doc, [trs(node, p) for p in pts]


def plain_tetra():
    pts = [(0.0, 0.0, 0.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0)]
    pos = pack_vec3("f32", pts, 12)
    idx = struct.pack("<12H", *[i for t in TETRA for i in t])
    return pts, pos, idx


def meshopt(fallback_data, required):
    pts, pos, idx = plain_tetra()
    junk = bytes(range(40))  # stands for the compressed stream, never read
    b0 = {"byteLength": len(pos) + len(idx),
          "extensions": {"EXT_meshopt_compression": {"fallback": True}}}
    if fallback_data:
        b0["uri"] = data_uri(pos + idx)
    ext = lambda n, mode, stride, count: {"EXT_meshopt_compression": {
        "buffer": 1, "byteOffset": 0, "byteLength": n, "byteStride": stride, "count": count, "mode": mode}}
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos), "byteStride": 12,
              "extensions": ext(30, "ATTRIBUTES", 12, 4)},
             {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx),
              "extensions": ext(10, "TRIANGLES", 2, 12)}]
    acc = [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
            "min": [0, 0, 0], "max": [1, 1, 1]},
           {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}]
    extra = {"extensionsUsed": ["EXT_meshopt_compression"]}
    if required:
        extra["extensionsRequired"] = ["EXT_meshopt_compression"]
    doc = gltf_doc(acc, views, [b0, {"byteLength": len(junk), "uri": data_uri(junk)}], {"mesh": 0},
                   extra, indices=1)
    return doc, [list(p) for p in pts]


def tetra_doc(extra=None, node=None):
    pts, pos, idx = plain_tetra()
    blob = pos + idx
    acc = [{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
            "min": [0, 0, 0], "max": [1, 1, 1]},
           {"bufferView": 1, "componentType": 5123, "count": 12, "type": "SCALAR"}]
    views = [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
             {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)}]
    node = node or {"mesh": 0}
    doc = gltf_doc(acc, views, [{"byteLength": len(blob), "uri": data_uri(blob)}], node, extra, indices=1)
    return doc, [trs(node, p) for p in pts]


def gltf_files():
    files = {}
    for kind in ("i8", "u8", "i16", "u16"):
        for norm in (False, True):
            doc, want = quantized(kind, norm)
            files["quantized_%s%s.gltf" % (kind, "_norm" if norm else "")] = (doc, {"positions": want, "triangles": 4})
    for base in (True, False):
        doc, want = sparse(base)
        # Without a base view vertices 0 and 1 are both zero: triangle
        # (0, 1, 2) is degenerate and dropped, (0, 2, 3) stays.
        files["sparse_%s.gltf" % ("base" if base else "no_base")] = (doc, {"positions": want,
                                                                          "triangles": 2 if base else 1})
    for req in (False, True):
        doc, want = meshopt(True, req)
        files["meshopt_fallback%s.gltf" % ("_required" if req else "")] = (doc, {"positions": want, "triangles": 4})
    doc, _ = meshopt(False, True)
    files["meshopt_no_fallback.gltf"] = (doc, {"error": ["EXT_meshopt_compression", "re-export"]})
    # Draco required: the positions exist only compressed.
    doc, _ = tetra_doc({"extensionsUsed": ["KHR_draco_mesh_compression"],
                        "extensionsRequired": ["KHR_draco_mesh_compression"]})
    del doc["accessors"][0]["bufferView"]
    doc["meshes"][0]["primitives"][0]["extensions"] = {
        "KHR_draco_mesh_compression": {"bufferView": 1, "attributes": {"POSITION": 0}}}
    files["draco_required.gltf"] = (doc, {"error": ["KHR_draco_mesh_compression",
                                                    "re-export without Draco compression"]})
    # Draco used with uncompressed accessors kept: read those.
    doc, want = tetra_doc({"extensionsUsed": ["KHR_draco_mesh_compression"]})
    doc["meshes"][0]["primitives"][0]["extensions"] = {
        "KHR_draco_mesh_compression": {"bufferView": 1, "attributes": {"POSITION": 0}}}
    files["draco_used_uncompressed_kept.gltf"] = (doc, {"positions": want, "triangles": 4})
    doc, _ = tetra_doc({"extensionsUsed": ["EXT_mesh_gpu_instancing"],
                        "extensionsRequired": ["EXT_mesh_gpu_instancing"]})
    files["unknown_required.gltf"] = (doc, {"error": ["EXT_mesh_gpu_instancing", "re-export without it"]})
    doc, want = tetra_doc({"extensionsUsed": ["KHR_materials_unlit"],
                           "extensionsRequired": ["KHR_materials_unlit"]})
    files["material_required.gltf"] = (doc, {"positions": want, "triangles": 4,
                                             "warnings": ["KHR_materials_unlit"]})
    doc, _ = tetra_doc()
    doc["scenes"] = [{}]
    files["empty_scene.gltf"] = (doc, {"error": ["scene 0 is empty"]})
    # No scene: the root nodes (node 0 with its child 1), transforms applied.
    doc, _ = tetra_doc(node={"mesh": 0, "translation": [10, 0, 0], "children": [1]})
    del doc["scene"], doc["scenes"]
    child = {"mesh": 0, "scale": [2, 2, 2]}
    doc["nodes"].append(child)
    pts = plain_tetra()[0]
    want = [trs(doc["nodes"][0], p) for p in pts] + [trs(doc["nodes"][0], trs(child, p)) for p in pts]
    files["no_scene_root_nodes.gltf"] = (doc, {"positions": want, "triangles": 8, "warnings": ["no scene"]})
    doc, want = tetra_doc()
    del doc["scene"], doc["scenes"], doc["nodes"]
    files["no_scene_no_nodes.gltf"] = (doc, {"positions": [list(p) for p in pts], "triangles": 4,
                                             "warnings": ["no scene and no nodes"]})
    return files


def main():
    expected = {"vox": {}, "gltf": {}}
    os.makedirs(os.path.join(HERE, "vox"), exist_ok=True)
    os.makedirs(os.path.join(HERE, "gltf"), exist_ok=True)
    for name, (v, warns) in sorted(vox_files().items()):
        with open(os.path.join(HERE, "vox", name), "wb") as f:
            f.write(v.bytes())
        expected["vox"][name] = {"voxels": [list(p) for p in v.world()], "warnings": warns}
    for name, (doc, want) in sorted(gltf_files().items()):
        with open(os.path.join(HERE, "gltf", name), "w") as f:
            json.dump(doc, f, indent=1)
            f.write("\n")
        expected["gltf"][name] = want
    with open(os.path.join(HERE, "vox_gltf_expected.json"), "w") as f:
        json.dump(expected, f, indent=1, sort_keys=True)
        f.write("\n")


if __name__ == "__main__":
    main()
