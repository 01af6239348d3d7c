#!/usr/bin/env python3
"""Writes voxkit's NIfTI conformance files (tests/data/formats/nifti/) and their
answers (nifti_expected.json) with nibabel, an implementation independent of
voxkit's reader.

The answers are what nibabel reads back from each file it wrote: the samples
(`get_fdata()`, so scaled where the header scales, x fastest) and the placement
(`get_sform()` where sform_code > 0, else `get_qform()` where qform_code > 0).
Where both codes are 0 the answer is NIfTI's "method 1" (x = pixdim * index,
origin 0), which the standard gives; nibabel centres such images instead.

Run from the repository root, with nibabel (5.x) and numpy installed:
    python3 tests/data/formats/make_nifti.py
"""
import json
import os

import nibabel as nib
import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(HERE, "nifti")
ROOT = os.path.dirname(os.path.dirname(os.path.dirname(HERE)))


def grid(shape):
    """Index arrays i, j, k (x, y, z) of a 3-D shape."""
    return np.meshgrid(*[np.arange(n) for n in shape], indexing="ij")


def rotation(axis, degrees):
    a = np.radians(degrees)
    c, s = np.cos(a), np.sin(a)
    u = np.asarray(axis, float) / np.linalg.norm(axis)
    x, y, z = u
    return np.array(
        [
            [c + x * x * (1 - c), x * y * (1 - c) - z * s, x * z * (1 - c) + y * s],
            [y * x * (1 - c) + z * s, c + y * y * (1 - c), y * z * (1 - c) - x * s],
            [z * x * (1 - c) - y * s, z * y * (1 - c) + x * s, c + z * z * (1 - c)],
        ]
    )


def affine(rot, spacing, origin):
    a = np.eye(4)
    a[:3, :3] = rot @ np.diag(spacing)
    a[:3, 3] = origin
    return a


def header(cls, big):
    h = cls()
    if big:
        h = h.as_byteswapped(">")
    return h


def save(name, img, answers, method1=None):
    path = os.path.join(OUT, name)
    nib.save(img, path)
    back = nib.load(path)
    h = back.header
    data = np.asarray(back.get_fdata(dtype=np.float64))
    while data.ndim > 3:
        assert data.shape[-1] == 1
        data = data[..., 0]
    while data.ndim < 3:
        data = data[..., np.newaxis]
    if int(h["sform_code"]) > 0:
        aff, space = back.get_sform(), "RAS"
    elif int(h["qform_code"]) > 0:
        aff, space = back.get_qform(), "RAS"
    else:
        aff, space = affine(np.eye(3), method1, [0, 0, 0]), None
    stored = h.get_data_dtype()
    # The image's header forgets the scaling once read; the array proxy keeps it.
    slope, inter = float(back.dataobj.slope), float(back.dataobj.inter)
    scaled = np.isfinite(slope) and slope != 0 and (slope, inter) != (1.0, 0.0)
    answers.append(
        {
            "file": name,
            "dims": list(data.shape),
            "stored": stored.name,
            "scaled": bool(scaled),
            "big_endian": stored.byteorder == ">",
            # x fastest, as voxkit stores samples.
            "values": [float(v) for v in data.ravel(order="F")],
            "origin": [float(v) for v in aff[:3, 3]],
            "axes": [[float(v) for v in aff[:3, c]] for c in range(3)],
            "space": space,
        }
    )


def main():
    os.makedirs(OUT, exist_ok=True)
    answers = []

    i, j, k = grid((5, 4, 3))
    a = affine(rotation([0, 0, 1], 30), [0.8, 1.2, 2.5], [-10.0, 4.5, 7.25])
    img = nib.Nifti1Image(((i + 5 * j + 20 * k) * 3).astype(np.uint8), a)
    img.set_sform(a, code=1)
    img.set_qform(None, code=0)
    save("u8_sform.nii", img, answers)

    # A left-handed frame: the quaternion with qfac = -1.
    a = affine(rotation([1, 2, 3], 70) @ np.diag([1, 1, -1]), [0.9, 1.1, 3.0], [5, -6, 7])
    v = (i - 5 * j + 100 * k - 300).astype(">i2")
    img = nib.Nifti1Image(v, a, header=header(nib.Nifti1Header, True))
    img.set_data_dtype(">i2")
    img.set_qform(a, code=1)
    img.set_sform(None, code=0)
    save("i16_qform_be.nii", img, answers)

    # Floats stored as int16 with nibabel's own slope and intercept.
    v = (np.sin(i * 0.7) * 300 + j * 11.5 - k * 40.25).astype(np.float64)
    img = nib.Nifti1Image(v, a)
    img.set_data_dtype(np.int16)
    save("i16_scaled.nii.gz", img, answers)

    img = nib.Nifti1Pair((i * 1000 + j * 10 + k).astype(np.uint16), a)
    save("u16_pair.hdr", img, answers)

    v = np.cos(i * 0.3 + j * 0.2) * 1e3 + k * 1e-3
    img = nib.Nifti2Image(v.astype(np.float64), affine(np.eye(3), [0.5, 0.5, 0.7], [1, 2, 3]))
    save("f64_nifti2.nii", img, answers)

    v = (np.arange(60, dtype=np.float32).reshape(5, 4, 3) * -0.25).astype(">f4")
    img = nib.Nifti2Image(v, a, header=header(nib.Nifti2Header, True))
    img.set_data_dtype(">f4")
    img.set_qform(a, code=2)
    img.set_sform(None, code=0)
    save("f32_nifti2_be.nii.gz", img, answers)

    v = (i - 2 * j + 7 * k - 10).astype(np.int8)[..., np.newaxis]
    save("i8_4d.nii", nib.Nifti1Image(v, a), answers)

    v = (i * 100000 + j * 1000 + k).astype(np.uint32)
    img = nib.Nifti1Image(v, None)
    img.header.set_zooms((2.0, 3.0, 4.0))
    img.set_sform(None, code=0)
    img.set_qform(None, code=0)
    save("u32_method1.nii", img, answers, method1=[2.0, 3.0, 4.0])

    ii, jj = np.meshgrid(np.arange(6), np.arange(5), indexing="ij")
    v = (ii * 7 - jj * 300000).astype(np.int32)
    save("i32_2d.nii", nib.Nifti1Image(v, affine(np.eye(3), [1.5, 2.5, 1.0], [0, 0, 0])), answers)

    # A real MR volume, as the .mhd beside it places it (spacing 4, origin 0).
    mr = os.path.join(ROOT, "data", "volumes", "HeadMRVolume", "HeadMRVolume.raw")
    raw = np.fromfile(mr, dtype=np.uint8).reshape((42, 62, 48)).transpose(2, 1, 0)
    img = nib.Nifti1Image(raw, affine(np.eye(3), [4.0, 4.0, 4.0], [0, 0, 0]))
    nib.save(img, os.path.join(OUT, "headmr.nii.gz"))

    with open(os.path.join(HERE, "nifti_expected.json"), "w") as f:
        json.dump(answers, f, indent=1)
        f.write("\n")


if __name__ == "__main__":
    main()
