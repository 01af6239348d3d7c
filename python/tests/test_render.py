"""render and read_volume: shapes, the ray caster's exactness promises
through the binding, and the CLI's defaults."""

import numpy as np
import pytest

import voxkit
from conftest import CT_HEAD, ROOT, SPOT, TEAPOT


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


@pytest.mark.parametrize(
    "value",
    [np.uint32(2**32 - 1), np.int32(-(2**31)), np.float32(3.4e38), np.float64(-1e300)],
)
def test_uniform_volumes_of_any_magnitude_render(value):
    """A uniform volume gets a proper default window and iso value even
    where `v ± 0.5` rounds back to `v` (a uint32 mask of 2**32 - 1)."""
    import contextlib

    arr = np.full((5, 4, 3), value)
    # -1e300 lies beyond float32's range: a warning says so (see below).
    beyond = abs(float(value)) > float(np.finfo(np.float32).max)
    for volume, method in [("mip", "rays"), ("composite", "shear-warp"), ("iso", "rays")]:
        with pytest.warns(UserWarning, match="beyond float32") if beyond else contextlib.nullcontext():
            rgb, depth = voxkit.render(arr, size=(12, 10), volume=volume, method=method)
        assert rgb.shape == (10, 12, 3)


def test_float64_beyond_float32_is_a_warning():
    """float64 samples beyond float32's range (a -1e300 "no data" sentinel)
    render as +-inf, and `render` says how many, as the CLI does; a volume
    within range, its extremes included, renders without a warning."""
    import warnings

    arr = np.tile(np.array([0.5, -1e300, 2.0, 1e39]), 15).reshape(5, 4, 3)
    for method in ["rays", "shear-warp"]:
        with pytest.warns(UserWarning, match=r"^volume: 30 float64 samples lie beyond float32's range"):
            rgb, _ = voxkit.render(arr, size=(12, 10), method=method)
        assert rgb.shape == (10, 12, 3)
    inside = np.tile(np.array([0.5, -3e38, 2.0, 1e-300, np.inf, np.nan]), 10).reshape(5, 4, 3)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        voxkit.render(inside, size=(12, 10))


@pytest.mark.parametrize(
    "values, same_as",
    [
        (np.arange(60) % 7, np.uint8),  # NumPy's default int64: small labels
        (np.arange(60) * 1000 - 30000, np.int32),
        (np.arange(60, dtype=np.int64) * (1 << 36), np.float64),  # beyond 32 bits
        (np.arange(60, dtype=np.uint64) * 3, np.uint8),
        (np.linspace(-2, 5, 60).astype(np.float16), np.float32),
    ],
)
def test_wide_integer_and_half_arrays_render_as_their_values(values, same_as):
    """int64 / uint64 (NumPy's default integers) and float16 arrays render
    exactly as the same values in a type voxkit holds, in every mode."""
    arr = values.reshape(5, 4, 3)
    for volume, method in [("mip", "rays"), ("composite", "shear-warp"), ("iso", "rays")]:
        got = voxkit.render(arr, size=(16, 12), volume=volume, method=method)
        want = voxkit.render(arr.astype(same_as), size=(16, 12), volume=volume, method=method)
        for g, w in zip(got, want):
            assert np.array_equal(g, w), (values.dtype, volume)


def test_nifti_reads_as_its_metaimage():
    """A gzipped NIfTI-1 written by nibabel holds the MR volume of the .mhd."""
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
    from conftest import read_png_rgb

    g = tmp_path / "spot.binvox"
    spot.save(g)
    png = tmp_path / "spot.png"
    cli("render", g, "-o", png, "--size", "64x48", "-q")
    rgb, _ = voxkit.render(voxkit.load_grid(g), size=(64, 48))
    assert np.array_equal(rgb, read_png_rgb(png))


NIFTI = ROOT / "tests" / "data" / "formats" / "nifti"


def test_read_volume_keeps_the_nifti_frame():
    """Rotated, flipped and scaled NIfTI frames reach Python whole: the
    axes, origin and space nibabel gives for the same files."""
    import json

    expected = json.loads((ROOT / "tests" / "data" / "formats" / "nifti_expected.json").read_text())
    assert len(expected) >= 8
    for e in expected:
        vol = voxkit.read_volume(NIFTI / e["file"])
        assert isinstance(vol, tuple) and len(vol) == 3
        assert list(vol.array.shape) == e["dims"], e["file"]
        cols = np.array(e["axes"])  # each row: one grid axis's world step
        assert np.allclose(vol.axes.T, cols, rtol=0, atol=1e-6), e["file"]
        assert np.allclose(vol.origin, e["origin"], rtol=0, atol=1e-6), e["file"]
        assert np.allclose(vol.spacing, np.linalg.norm(cols, axis=1)), e["file"]
        assert vol.space == e["space"], e["file"]


@pytest.mark.parametrize("name", ["i16_qform_be.nii", "u8_sform.nii", "headmr.nii.gz"])
def test_oblique_volume_renders_as_the_cli(cli, tmp_path, name):
    """render(read_volume(f)) draws what `voxkit render f` draws: the
    rotated or flipped axes and the RAS space are kept, not only the
    spacing."""
    from conftest import read_png_rgb

    png = tmp_path / "v.png"
    cli("render", NIFTI / name, "-o", png, "--size", "64x48", "-q")
    vol = voxkit.read_volume(NIFTI / name)
    rgb, depth = voxkit.render(vol, size=(64, 48))
    assert np.array_equal(rgb, read_png_rgb(png))
    # The frame matters: the spacing alone draws another picture.
    arr, spacing, origin = vol
    plain, _ = voxkit.render(arr, spacing=spacing, origin=origin, size=(64, 48))
    assert not np.array_equal(plain, rgb)


def test_render_axes_and_space_are_checked():
    arr = np.arange(27, dtype=np.float32).reshape(3, 3, 3)
    with pytest.raises(ValueError, match="3x3"):
        voxkit.render(arr, axes=np.eye(2), size=(8, 8))
    with pytest.raises(ValueError, match="singular"):
        voxkit.render(arr, axes=np.zeros((3, 3)), size=(8, 8))
    with pytest.raises(ValueError, match="space"):
        voxkit.render(arr, space="XYZ", size=(8, 8))
    flipped = np.diag([-1.0, 1.0, 1.0])
    a, _ = voxkit.render(arr, axes=flipped, size=(16, 16), view="front")
    b, _ = voxkit.render(arr[::-1].copy(), origin=(-2.0, 0.0, 0.0), size=(16, 16), view="front")
    assert np.array_equal(a, b)


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
