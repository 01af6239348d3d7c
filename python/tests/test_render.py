"""render and read_volume: shapes, the ray caster's exactness promises
through the binding, and the CLI's defaults."""

import numpy as np
import pytest

import voxkit
from conftest import CT_HEAD, SPOT, TEAPOT


@pytest.fixture(scope="module")
def spot():
    return voxkit.voxelize(*voxkit.load_mesh(SPOT), resolution=64)


def test_grid_image_shapes_and_background(spot):
    rgb, depth = voxkit.render(spot, size=(80, 60))
    assert rgb.shape == (60, 80, 3) and rgb.dtype == np.uint8 and rgb.flags.c_contiguous
    assert depth.shape == (60, 80) and depth.dtype == np.float32
    miss = np.isinf(depth)
    assert 0 < miss.sum() < depth.size  # framed: the object is in view, with margin
    bg = np.round(np.clip(np.array([0.07, 0.08, 0.1]), 0, 1) * 255).astype(np.uint8)
    assert (rgb[miss] == bg).all()
    assert (depth[~miss] > 0).all()


def test_adaptive_and_skipping_match_the_six_ray(spot):
    kw = dict(size=(96, 96), eye=(2.0, 1.5, 2.5), target=(0.0, 0.3, 0.0), up=(0, 1, 0))
    six = voxkit.render(spot, ray="6", skip=False, **kw)
    for ray, skip in [("adaptive", True), ("adaptive", False), ("6", True)]:
        rgb, depth = voxkit.render(spot, ray=ray, skip=skip, **kw)
        assert np.array_equal(depth, six[1]) and np.array_equal(rgb, six[0]), (ray, skip)


def test_views_ortho_and_normals(spot):
    a = voxkit.render(spot, size=(32, 32), view="front")[1]
    b = voxkit.render(spot, size=(32, 32), view="top", ortho=True, normals="face")[1]
    assert np.isfinite(a).any() and np.isfinite(b).any() and not np.array_equal(a, b)


def test_read_volume_and_render_it():
    arr, spacing, origin = voxkit.read_volume(CT_HEAD)
    assert arr.ndim == 3 and arr.dtype == np.int16 and arr.flags.f_contiguous
    assert spacing.shape == (3,) and origin.shape == (3,)
    assert arr.shape == (64, 64, 93)
    np.testing.assert_allclose(spacing, [3.2, 3.2, 1.5])
    for mode in ["mip", "composite", "iso"]:
        rgb, depth = voxkit.render((arr, spacing, origin), size=(48, 40), volume=mode)
        assert rgb.shape == (40, 48, 3) and rgb.any()
    # Shear-warp: close to the rays' image (not equal), and the same image
    # as the command line's.
    rays = voxkit.render((arr, spacing, origin), size=(64, 64), volume="composite")[0]
    sw = voxkit.render((arr, spacing, origin), size=(64, 64), volume="composite", method="shear-warp")[0]
    assert not np.array_equal(rays, sw)
    assert np.abs(rays.astype(int) - sw.astype(int)).mean() < 4.0
    with pytest.raises(ValueError, match="method"):
        voxkit.render((arr, spacing, origin), size=(8, 8), method="splat")
    # The same samples in C order render the same image.
    c = np.ascontiguousarray(arr)
    assert np.array_equal(
        voxkit.render(c, spacing=spacing, origin=origin, size=(32, 32))[0],
        voxkit.render((arr, spacing, origin), size=(32, 32))[0],
    )


def test_nifti_reads_as_its_metaimage():
    """A gzipped NIfTI-1 written by nibabel holds the MR volume of the .mhd."""
    from conftest import ROOT

    mhd = voxkit.read_volume(ROOT / "data" / "volumes" / "HeadMRVolume" / "HeadMRVolume.mhd")
    nii = voxkit.read_volume(ROOT / "tests" / "data" / "formats" / "nifti" / "headmr.nii.gz")
    assert nii[0].dtype == np.uint8 and nii[0].shape == (48, 62, 42)
    for a, b in zip(mhd, nii):
        assert np.array_equal(a, b)


def test_binary_array_renders_as_voxels(spot):
    d = spot.dense()
    rgb_b, depth_b = voxkit.render(d, size=(40, 40), spacing=(spot.voxel_size,) * 3, origin=spot.origin + spot.voxel_size / 2)
    rgb_g, depth_g = voxkit.render(spot, size=(40, 40))
    assert np.array_equal(np.isinf(depth_b), np.isinf(depth_g))
    assert np.array_equal(rgb_b, rgb_g)


def test_png_matches_the_cli(cli, tmp_path, spot):
    """The CLI's PNG holds the same pixels (decoded with the stdlib's zlib)."""
    import struct
    import zlib

    g = tmp_path / "spot.binvox"
    spot.save(g)
    png = tmp_path / "spot.png"
    cli("render", g, "-o", png, "--size", "64x48", "-q")
    data = png.read_bytes()
    chunks, i = [], 8
    while i < len(data):
        n, kind = struct.unpack(">I4s", data[i:i + 8])
        chunks.append((kind, data[i + 8:i + 8 + n]))
        i += 12 + n
    w, h, depth, ctype = struct.unpack(">IIBB", chunks[0][1][:10])
    assert (w, h, depth) == (64, 48, 8)
    raw = zlib.decompress(b"".join(c for k, c in chunks if k == b"IDAT"))
    bpp = {2: 3, 6: 4}[ctype]
    stride = w * bpp
    rows, prev = [], bytearray(stride)
    for y in range(h):
        f, line = raw[y * (stride + 1)], bytearray(raw[y * (stride + 1) + 1:(y + 1) * (stride + 1)])
        for x in range(stride):
            a = line[x - bpp] if x >= bpp else 0
            b, c = prev[x], prev[x - bpp] if x >= bpp else 0
            p = a + b - c
            pred = [0, a, b, (a + b) // 2, a if abs(p - a) <= abs(p - b) and abs(p - a) <= abs(p - c) else (b if abs(p - b) <= abs(p - c) else c)][f]
            line[x] = (line[x] + pred) & 0xFF
        rows.append(bytes(line))
        prev = line
    cli_rgb = np.frombuffer(b"".join(rows), np.uint8).reshape(h, w, bpp)[..., :3]
    rgb, _ = voxkit.render(voxkit.load_grid(g), size=(64, 48))
    assert np.array_equal(rgb, cli_rgb)


def test_render_pixels_is_a_window_of_the_frame(tmp_path):
    g = voxkit.voxelize(*voxkit.load_mesh(TEAPOT), resolution=64)
    rgb, depth = voxkit.render(g, size=(120, 90))
    part, pdepth = voxkit.render(g, size=(120, 90), pixels=(17, 33, 50, 41))
    assert part.shape == (41, 50, 3) and np.isfinite(pdepth).any()
    assert np.array_equal(part, rgb[33:74, 17:67]) and np.array_equal(pdepth, depth[33:74, 17:67])
    with pytest.raises(ValueError, match="not inside"):
        voxkit.render(g, size=(120, 90), pixels=(100, 0, 30, 10))
    voxkit.write_png(tmp_path / "w.png", part)
    with pytest.raises((ValueError, OSError)):
        voxkit.write_png(tmp_path / "w.png", part)  # exists, no overwrite
    voxkit.write_png(tmp_path / "w.png", part, overwrite=True)
