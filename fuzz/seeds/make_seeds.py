#!/usr/bin/env python3
"""Writes the seed corpus of every fuzz target into fuzz/corpus/<target>/
(not committed: run this before the first `cargo fuzz run`). Seeds are tiny
valid files of each format, written here by hand (independently of voxkit's
writers), plus snippets of the repository's test data."""
import gzip
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(os.path.dirname(HERE))
CORPUS = os.path.join(os.path.dirname(HERE), "corpus")


def put(target, name, data):
    d = os.path.join(CORPUS, target)
    os.makedirs(d, exist_ok=True)
    if isinstance(data, str):
        data = data.encode()
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def head_lines(path, n):
    with open(path, "rb") as f:
        return b"".join(f.readlines()[:n])


# A 3x2x2 occupancy pattern, x fastest.
DIMS = (3, 2, 2)
OCC = [1, 0, 1, 1, 1, 0, 0, 0, 1, 1, 0, 1]


def obj():
    put("obj", "quad", "v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1 2 3 4\nl -4 -2 -1\n")
    put("obj", "tet", "o t\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nvn 0 0 1\nvt 0 0\n"
        "f 1/1/1 3/1/1 2/1/1\nf 1//1 2//1 4//1\nf 1 4 3\nf 2 3 4\ng g\nusemtl m\np 1\n")
    for f in ["spot.obj", "teapot.obj", "fandisk.obj"]:
        put("obj", f, head_lines(os.path.join(ROOT, "data/meshes/obj", f), 60))


def binvox():
    n = 3
    cells = [0] * n ** 3
    # binvox order: x slowest... y fastest (index = x*n*n + z*n + y)
    for i in (0, 5, 13, 26):
        cells[i] = 1
    runs = []
    for v in cells:
        if runs and runs[-1][0] == v and runs[-1][1] < 255:
            runs[-1][1] += 1
        else:
            runs.append([v, 1])
    body = bytes(b for r in runs for b in r)
    put("binvox", "cube3", b"#binvox 1\ndim 3 3 3\ntranslate 0 0 0\nscale 1\ndata\n" + body)
    put("binvox", "empty2", b"#binvox 1\ndim 2 2 2\ntranslate -1.5 2 0.25\nscale 0.5\ndata\n\x00\x08")


def npy_bytes(descr, shape, payload, fortran=False):
    h = "{'descr': '%s', 'fortran_order': %s, 'shape': (%s), }" % (
        descr, "True" if fortran else "False", ", ".join(str(s) for s in shape) + ("," if len(shape) == 1 else ""))
    pad = 64 - (10 + len(h) + 1) % 64
    h = h + " " * pad + "\n"
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(h)) + h.encode() + payload


def c_order(vals):
    # OCC is x fastest; C order of shape [nx, ny, nz] is z fastest.
    nx, ny, nz = DIMS
    return [vals[x + nx * (y + ny * z)] for x in range(nx) for y in range(ny) for z in range(nz)]


def npy():
    put("npy", "u1", npy_bytes("|u1", DIMS, bytes(c_order(OCC))))
    put("npy", "b1", npy_bytes("|b1", DIMS, bytes(c_order(OCC))))
    put("npy", "u1_fortran", npy_bytes("|u1", DIMS, bytes(OCC), fortran=True))


def nrrd():
    hdr = ("NRRD0004\n# voxels\ntype: uchar\ndimension: 3\nspace dimension: 3\nsizes: 3 2 2\n"
           "space directions: (0.5,0,0) (0,0.5,0) (0,0,0.5)\nkinds: domain domain domain\n"
           "encoding: raw\nspace origin: (0.25,0.25,0.25)\n\n")
    put("nrrd", "u8", hdr.encode() + bytes(OCC))
    put("nrrd", "spacings", b"NRRD0005\ntype: uint8\ndimension: 3\nsizes: 3 2 2\nspacings: 2 2 2\n"
        b"encoding: raw\n\n" + bytes(OCC))


def chunk(cid, content, children=b""):
    return cid + struct.pack("<ii", len(content), len(children)) + content + children


def vdict(d):
    out = struct.pack("<i", len(d))
    for k, v in d.items():
        out += struct.pack("<i", len(k)) + k.encode() + struct.pack("<i", len(v)) + v.encode()
    return out


def vox():
    size = chunk(b"SIZE", struct.pack("<iii", 3, 2, 2))
    vs = [(x, y, z) for z in range(2) for y in range(2) for x in range(3) if OCC[x + 3 * (y + 2 * z)]]
    xyzi = chunk(b"XYZI", struct.pack("<i", len(vs)) + b"".join(bytes([x, y, z, 1 + x]) for x, y, z in vs))
    put("vox", "plain", b"VOX " + struct.pack("<i", 150) + chunk(b"MAIN", b"", size + xyzi))
    rgba = chunk(b"RGBA", bytes((i * 7) % 256 for i in range(1024)))
    ntrn0 = chunk(b"nTRN", struct.pack("<i", 0) + vdict({}) + struct.pack("<iiii", 1, -1, -1, 1) + vdict({}))
    ngrp = chunk(b"nGRP", struct.pack("<i", 1) + vdict({}) + struct.pack("<ii", 2, 2) + struct.pack("<i", 4))
    ntrn2 = chunk(b"nTRN", struct.pack("<i", 2) + vdict({}) + struct.pack("<iiii", 3, -1, 0, 1) + vdict({"_t": "10 -4 3"}))
    nshp3 = chunk(b"nSHP", struct.pack("<i", 3) + vdict({}) + struct.pack("<i", 1) + struct.pack("<i", 0) + vdict({}))
    ntrn4 = chunk(b"nTRN", struct.pack("<i", 4) + vdict({}) + struct.pack("<iiii", 5, -1, 0, 1) + vdict({"_t": "0 0 0"}))
    nshp5 = chunk(b"nSHP", struct.pack("<i", 5) + vdict({}) + struct.pack("<i", 1) + struct.pack("<i", 1) + vdict({}))
    layr = chunk(b"LAYR", struct.pack("<i", 0) + vdict({}) + struct.pack("<i", -1))
    body = size + xyzi + size + xyzi + ntrn0 + ngrp + ntrn2 + nshp3 + ntrn4 + nshp5 + layr + rgba
    put("vox", "scene", b"VOX " + struct.pack("<i", 150) + chunk(b"MAIN", b"", body))
    # The conformance corpus: instancing, every rotation, nested groups,
    # hidden layers and nodes, keyframes, the 0.98 animation layout.
    corpus("vox", "vox")


def corpus(target, sub):
    """Seeds from tests/data/formats/<sub>/ (make_vox_gltf.py's files)."""
    d = os.path.join(ROOT, "tests/data/formats", sub)
    for name in sorted(os.listdir(d)):
        put(target, "formats-" + name, open(os.path.join(d, name), "rb").read())


SEP = b"\n@@DATA@@\n"  # voxkit::fuzz_entry::DATA_SEPARATOR


def samples(fmt):
    return struct.pack("<%d%s" % (len(OCC), fmt), *[v * 3 + (-1 if fmt.islower() else 1) for v in OCC])


def volume_nrrd():
    base = "NRRD0004\ntype: %s\ndimension: 3\nsizes: 3 2 2\n"
    put("volume_nrrd", "raw_i16", (base % "short" + "endian: little\nencoding: raw\n"
        "space directions: (1,0,0) (0,2,0) (0,0.5,1)\nspace origin: (1,2,3)\n\n").encode() + samples("h"))
    put("volume_nrrd", "gzip_f32", (base % "float" + "endian: big\nencoding: gzip\nspacings: 1 1 2\n\n").encode()
        + gzip.compress(struct.pack(">12f", *[float(v) for v in OCC])))
    put("volume_nrrd", "ascii_u8", (base % "uchar" + "encoding: ascii\n\n" + " ".join(map(str, OCC))).encode())
    put("volume_nrrd", "detached_u16", (base % "ushort" + "endian: little\nencoding: raw\nbyte skip: -1\n"
        "data file: d.raw\n").encode() + SEP + b"junk" + samples("H"))
    put("volume_nrrd", "detached_list", (base % "int8" + "encoding: raw\nline skip: 1\ndata file: LIST 2\na.raw\nb.raw\n").encode()
        + SEP + b"skip me\n" + bytes(OCC[:6]))
    put("volume_nrrd", "detached_pattern", (base % "uint" + "endian: little\nencoding: raw\n"
        "data file: s%03d.raw 1 2 1\n").encode() + SEP + struct.pack("<6I", *range(6)))


def volume_meta():
    base = "ObjectType = Image\nNDims = 3\nDimSize = 3 2 2\nElementSpacing = 1 1 2\nOffset = 0 1 2\n"
    put("volume_meta", "mha_raw", (base + "ElementType = MET_SHORT\nElementDataFile = LOCAL\n").encode() + samples("h"))
    put("volume_meta", "mha_zlib", (base + "ElementType = MET_FLOAT\nBinaryDataByteOrderMSB = True\nCompressedData = True\n"
        "TransformMatrix = 0 1 0 1 0 0 0 0 1\nElementDataFile = LOCAL\n").encode()
        + zlib.compress(struct.pack(">12f", *[float(v) for v in OCC])))
    put("volume_meta", "mha_text", (base + "BinaryData = False\nElementType = MET_DOUBLE\nElementDataFile = LOCAL\n"
        + ", ".join(str(v * 0.5) for v in OCC)).encode())
    put("volume_meta", "mhd_raw", (base + "ElementType = MET_UCHAR\nHeaderSize = -1\nElementDataFile = v.raw\n").encode()
        + SEP + b"hdr" + bytes(OCC))
    put("volume_meta", "mhd_list", (base + "ElementType = MET_CHAR\nElementDataFile = LIST 2D\na.raw\nb.raw\n").encode()
        + SEP + bytes(OCC[:6]))
    put("volume_meta", "mhd_pattern", (base + "ElementType = MET_UINT\nElementDataFile = s%d.raw 0 1 1\n").encode()
        + SEP + struct.pack("<6I", *range(6)))


def volume_npy():
    for descr, fmt in [("<i2", "<12h"), (">u2", ">12H"), ("<i4", "<12i"), ("<u4", "<12I"),
                       ("<f4", "<12f"), (">f8", ">12d"), ("|i1", "12b")]:
        vals = [v * 3 - 1 for v in c_order(OCC)]
        if "u" in descr:
            vals = [abs(v) for v in vals]
        put("volume_npy", descr.replace("<", "le_").replace(">", "be_").replace("|", ""),
            npy_bytes(descr, DIMS, struct.pack(fmt, *vals)))
    put("volume_npy", "b1_fortran", npy_bytes("|b1", DIMS, bytes(OCC), fortran=True))


def volume_nifti():
    """tests/data/formats/nifti/ (make_nifti.py's files): single files as they
    are, the .hdr/.img pair joined at the separator."""
    d = os.path.join(ROOT, "tests/data/formats/nifti")
    for name in sorted(os.listdir(d)):
        data = open(os.path.join(d, name), "rb").read()
        if name.endswith(".img") or len(data) > 65536:
            continue
        if name.endswith(".hdr"):
            data += SEP + open(os.path.join(d, name[:-4] + ".img"), "rb").read()
        put("volume_nifti", "formats-" + name, data)


def line():
    put("line", "few", "0 0 0 5 3 -2\n\n0.5 0.25 -1 -7.5 2 9\n1e1 0 0 -1e1 0.49999 3\n")
    put("line", "args", "--algo adaptive --flag-box -1,-1,-1,1,1,1 0 0 0 3 3 3\n2 2 2 -4 1 0\n")
    put("line", "tripod", "--algo tripod 0 0 0 1 1 1 4 4 4 0 0 0\n")


def render():
    put("render", "default", "")
    put("render", "eye", "--eye 3,4,5 --target 0,1,0 --up 0,0,1 --fov 60 --size 8x6 --ray 6")
    put("render", "ortho", "--ortho --view front --turntable 4 --ray aw --no-skip --normals face")
    put("render", "volume", "--volume composite --window 0,5 --tf 0:0,2:0.5:#ff8000,5:1 --sampling trilinear")
    put("render", "iso", "--volume iso --iso 1.5 --view top --size 7x3 --ray 26")
    put("render", "raw_camera", b"\xff" + struct.pack("<18d", 3, 2, 5, 0, 0, 0, 0, 1, 0, 45, 2,
                                                        0, 0, 0, 1, 1, 1, 0.3) + b"\x05\x07")


TET_V = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1)]
TET_F = [(0, 2, 1), (0, 1, 3), (0, 3, 2), (1, 2, 3)]


def gltf():
    d = os.path.join(ROOT, "data/meshes/gltf")
    for name in sorted(os.listdir(d)):
        p = os.path.join(d, name)
        if name.endswith(".glb") and os.path.getsize(p) <= 65536:
            put("gltf", name, open(p, "rb").read())
    import base64
    import json
    pos = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    idx = struct.pack("<3H", 0, 1, 2) + b"\0\0"
    buf = pos + idx
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}],
           "nodes": [{"mesh": 0, "children": [1]}, {"mesh": 0, "translation": [1, 2, 3],
                                                     "rotation": [0, 0, 0.7071068, 0.7071068], "scale": [2, 2, 2]}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1},
                                      {"attributes": {"POSITION": 0}, "mode": 3}]}],
           "buffers": [{"byteLength": len(buf),
                        "uri": "data:application/octet-stream;base64," + base64.b64encode(buf).decode()}],
           "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": 36},
                           {"buffer": 0, "byteOffset": 36, "byteLength": 6}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                          "min": [0, 0, 0], "max": [1, 1, 0]},
                         {"bufferView": 1, "componentType": 5123, "count": 3, "type": "SCALAR"}]}
    text = json.dumps(doc).encode()
    put("gltf", "tri.gltf", text)
    doc["buffers"] = [{"byteLength": len(buf)}]
    j = json.dumps(doc).encode()
    j += b" " * (-len(j) % 4)
    body = struct.pack("<II", len(j), 0x4E4F534A) + j + struct.pack("<II", len(buf), 0x004E4942) + buf
    put("gltf", "tri.glb", b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body)
    # Sparse accessors, quantized positions, meshopt fallbacks, Draco and
    # unknown required extensions, empty scenes, files without scenes.
    corpus("gltf", "gltf")


def ply():
    head = "ply\nformat %s 1.0\ncomment fuzz seed\nelement vertex 4\nproperty float x\nproperty float y\n" \
           "property float z\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n"
    put("ply", "ascii", head % "ascii" + "".join("%d %d %d\n" % v for v in TET_V)
        + "".join("3 %d %d %d\n" % f for f in TET_F))
    put("ply", "binary_le", (head % "binary_little_endian").encode()
        + b"".join(struct.pack("<3f", *v) for v in TET_V) + b"".join(struct.pack("<B3i", 3, *f) for f in TET_F))
    head2 = head.replace("float", "double").replace("uchar int", "uint8 uint32").replace("face 4", "face 2")
    put("ply", "binary_be_double", (head2 % "binary_big_endian").encode()
        + b"".join(struct.pack(">3d", *v) for v in TET_V)
        + struct.pack(">B4I", 4, 0, 1, 2, 3) + struct.pack(">B3I", 3, 1, 2, 3))


def stl():
    tris = [[TET_V[i] for i in f] for f in TET_F]
    put("stl", "ascii", "solid t\n" + "".join(
        "facet normal 0 0 0\nouter loop\n" + "".join("vertex %d %d %d\n" % v for v in t) + "endloop\nendfacet\n"
        for t in tris) + "endsolid t\n")
    put("stl", "binary", b"\0" * 80 + struct.pack("<I", len(tris)) + b"".join(
        struct.pack("<12fH", 0, 0, 0, *[c for v in t for c in v], 0) for t in tris))


def off():
    put("off", "tet", "OFF\n# c\n4 4 6\n" + "".join("%d %d %d\n" % v for v in TET_V)
        + "".join("3 %d %d %d\n" % f for f in TET_F))
    put("off", "quad_colors", "OFF 4 1 0\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3 255 0 0\n")


for f in (gltf, ply, stl, off, obj, binvox, npy, nrrd, vox, volume_nrrd, volume_meta, volume_npy, volume_nifti, line,
          render):
    f()
