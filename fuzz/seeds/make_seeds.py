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


for f in (obj, binvox, npy, nrrd, vox, volume_nrrd, volume_meta, volume_npy, line, render):
    f()
