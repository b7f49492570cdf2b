import numpy as np
import pytest
from PIL import Image, ImageOps

from fluidnb import as_image, as_mask, to_uint8


def test_uint8_uint16_bool_float_convert_to_float32_01():
    u8 = np.array([[0, 51, 255]], np.uint8)
    assert as_image(u8) == pytest.approx(np.array([[0.0, 0.2, 1.0]]))
    u16 = np.array([[0, 65535]], np.uint16)
    assert as_image(u16).tolist() == [[0.0, 1.0]]
    assert as_image(np.array([[True, False]])).tolist() == [[1.0, 0.0]]
    f = np.array([[0.25, 0.5]], np.float64)
    out = as_image(f)
    assert out.dtype == np.float32
    assert out.tolist() == [[0.25, 0.5]]


def test_never_aliases_or_modifies_input():
    f = np.full((4, 4), 0.5, np.float32)
    out = as_image(f)
    out[:] = 0
    assert np.all(f == 0.5)


def test_channels_and_modes():
    rgba = np.zeros((2, 3, 4), np.uint8)
    rgba[..., 0] = 255
    rgba[..., 3] = 128
    rgb, alpha = as_image(rgba, return_alpha=True)
    assert rgb.shape == (2, 3, 3)
    assert alpha == pytest.approx(np.full((2, 3), 128 / 255))
    assert as_image(rgba).shape == (2, 3, 3)
    grey = as_image(rgba, mode="grey")
    assert grey.shape == (2, 3)
    assert grey[0, 0] == pytest.approx(0.2125)
    assert as_image(np.zeros((2, 3, 1), np.uint8)).shape == (2, 3)
    assert as_image(np.zeros((2, 3), np.uint8), mode="rgb").shape == (2, 3, 3)
    _, none = as_image(np.zeros((2, 3)), return_alpha=True)
    assert none is None


def test_a_cutout_composites_onto_a_background_and_its_clear_colour_vanishes(tmp_path):
    # Straight (PNG) alpha: a fully clear pixel's colour is junk and must vanish.
    rgba = np.zeros((2, 2, 4), np.uint8)
    rgba[0, 0] = (200, 100, 50, 255)  # opaque
    rgba[0, 1] = (255, 255, 255, 0)  # clear, holding white junk
    rgba[1, 0] = (255, 0, 0, 51)  # 20 % red
    rgba[1, 1] = (13, 200, 77, 0)  # clear, other junk
    over_black = as_image(rgba, background=0)
    np.testing.assert_allclose(over_black[0, 0], np.array([200, 100, 50]) / 255, atol=1e-6)
    assert not over_black[:, 1].any()
    np.testing.assert_allclose(over_black[1, 0], [0.2, 0, 0], atol=1e-6)
    over_grey = as_image(rgba, background=(0.5, 0.5, 0.5))
    np.testing.assert_allclose(over_grey[1, 1], [0.5, 0.5, 0.5])
    np.testing.assert_allclose(over_grey[1, 0], [0.2 + 0.4, 0.4, 0.4], atol=1e-6)
    # The alpha still comes back with return_alpha; from a file just the same.
    rgb, alpha = as_image(rgba, background=0, return_alpha=True)
    np.testing.assert_array_equal(rgb, over_black)
    np.testing.assert_allclose(alpha, [[1, 0], [0.2, 0]], atol=1e-6)
    Image.fromarray(rgba, mode="RGBA").save(tmp_path / "cut.png")
    np.testing.assert_array_equal(as_image(tmp_path / "cut.png", background=0), over_black)
    # Without alpha, or without background, nothing changes (backward compatible).
    np.testing.assert_array_equal(as_image(rgba[..., :3], background=0), as_image(rgba[..., :3]))
    np.testing.assert_array_equal(as_image(rgba)[0, 1], [1, 1, 1])
    with pytest.raises(ValueError, match="background must be a grey level or an RGB colour"):
        as_image(rgba, background=(1, 2))


def test_grey_with_alpha(tmp_path):
    la = np.zeros((2, 3, 2), np.uint8)
    la[..., 0] = 255
    la[0, :, 1] = 255
    grey, alpha = as_image(la, return_alpha=True)
    assert grey.shape == (2, 3)
    np.testing.assert_array_equal(alpha, [[1, 1, 1], [0, 0, 0]])
    np.testing.assert_array_equal(as_image(la, background=0), [[1, 1, 1], [0, 0, 0]])
    Image.fromarray(la, mode="LA").save(tmp_path / "la.png")
    _, from_file = as_image(tmp_path / "la.png", return_alpha=True)
    np.testing.assert_array_equal(from_file, alpha)


def test_paths_and_pil(tmp_path):
    arr = (np.arange(12, dtype=np.uint8).reshape(3, 4) * 20).astype(np.uint8)
    Image.fromarray(arr).save(tmp_path / "a.png")
    assert np.array_equal(as_image(tmp_path / "a.png"), arr / np.float32(255))
    assert np.array_equal(as_image(str(tmp_path / "a.png")), as_image(Image.fromarray(arr)))
    pal = Image.fromarray(np.stack([arr] * 3, -1)).convert("P")
    assert as_image(pal).shape == (3, 4, 3)


@pytest.mark.parametrize(
    ("bad", "message"),
    [
        (np.array([[np.nan, 0.5]]), "image contains NaN"),
        (np.array([[0.0, 2.0]]), r"floats must lie in \[0, 1\]"),
        (np.zeros(5), r"image must have shape \(H, W\)"),
        (np.zeros((2, 2, 5)), r"image must have shape \(H, W\)"),
        (np.zeros((0, 3)), "image is empty"),
        (np.zeros((2, 2), np.int64), "image has dtype int64"),
        ({"a": 1}, "must be a file path, a numpy array or a PIL image"),
        (np.array([["x"]]), "image has dtype"),
    ],
)
def test_bad_images(bad, message):
    with pytest.raises(ValueError, match=message):
        as_image(bad)


def test_bad_files(tmp_path):
    with pytest.raises(ValueError, match="no such file"):
        as_image(tmp_path / "missing.png")
    (tmp_path / "corrupt.png").write_bytes(b"not a png at all")
    with pytest.raises(ValueError, match="cannot read"):
        as_image(tmp_path / "corrupt.png", name="photo")
    with pytest.raises(ValueError, match="mode must be one of"):
        as_image(np.zeros((2, 2)), mode="hsv")


def test_as_mask():
    m = as_mask(np.array([[0, 200]], np.uint8), (1, 2))
    assert m.tolist() == [[False, True]]
    with pytest.raises(ValueError, match="region is empty"):
        as_mask(np.zeros((3, 3)), name="region")
    with pytest.raises(ValueError, match="must have the same height and width"):
        as_mask(np.ones((3, 3)), (3, 4))


def test_to_uint8_rounds_and_clips():
    assert to_uint8(np.array([-0.1, 0.0, 0.499 / 255, 0.5, 0.999, 1.2])).tolist() == [
        0,
        0,
        0,
        128,
        255,
        255,
    ]


def test_to_uint8_in_slabs_equals_the_whole_array_formula():
    # Larger than one slab (issue 39: converted through one scratch array), with a
    # strided view, a 0-d value and an empty array.
    from fluidnb._image import _SLAB

    rng = np.random.default_rng(4)
    clip = (rng.random((3, 301, 457, 3), dtype=np.float32) * 1.4 - 0.2).astype(np.float32)
    assert clip.size > 2 * _SLAB
    want = (np.clip(clip, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    assert np.array_equal(to_uint8(clip), want)
    assert np.array_equal(to_uint8(clip[:, ::2, 1:-1]), want[:, ::2, 1:-1])
    assert to_uint8(np.float32(0.5)) == 128
    assert to_uint8(np.zeros((0, 4), np.float32)).shape == (0, 4)


# ---------------------------------------------------------------- issue 37: hostile and huge files


def _png_header_only(path, width, height):
    """A PNG that declares width x height grey pixels and holds almost no data."""
    import struct
    import zlib

    def chunk(kind, data):
        body = kind + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body))

    header = struct.pack(">IIBBBBB", width, height, 8, 0, 0, 0, 0)
    path.write_bytes(
        b"\x89PNG\r\n\x1a\n"
        + chunk(b"IHDR", header)
        + chunk(b"IDAT", zlib.compress(b"\0" * 100))
        + chunk(b"IEND", b"")
    )
    return path


def test_a_decompression_bomb_is_a_value_error_naming_the_file(tmp_path):
    from fluidnb._image import image_size

    bomb = _png_header_only(tmp_path / "bomb.png", 30000, 30000)  # beyond Pillow's own limit
    for read in (as_image, as_mask, image_size):
        with pytest.raises(ValueError, match=r"photo: '.*bomb.png' declares 900 MP, more than"):
            read(bomb, name="photo")
    big = _png_header_only(tmp_path / "big.png", 9000, 6000)  # 54 MP: ours, not Pillow's
    with pytest.raises(ValueError, match=r"declares 9000 x 6000 pixels \(54 MP\)"):
        as_image(big)
    # Where Pillow only warns (89-179 MP), the one error is ours (warnings are errors here).
    bigger = _png_header_only(tmp_path / "bigger.png", 12000, 10000)
    with pytest.raises(ValueError, match=r"declares 12000 x 10000 pixels \(120 MP\)"):
        as_image(bigger)


def test_the_pixel_limit_is_refused_before_decoding_and_can_be_raised(tmp_path, monkeypatch):
    from fluidnb._image import MAX_PIXELS, image_size, max_pixels

    assert max_pixels() == MAX_PIXELS == 50_000_000
    Image.fromarray(np.full((30, 40), 7, np.uint8)).save(tmp_path / "small.png")
    monkeypatch.setenv("FLUIDNB_MAX_PIXELS", "1000")
    with pytest.raises(ValueError, match=r"declares 40 x 30 pixels.*more than the 0.001 MP"):
        as_image(tmp_path / "small.png")
    monkeypatch.setenv("FLUIDNB_MAX_PIXELS", "1200")
    assert as_image(tmp_path / "small.png").shape == (30, 40)
    assert image_size(tmp_path / "small.png") == (30, 40)
    monkeypatch.setenv("FLUIDNB_MAX_PIXELS", "lots")
    with pytest.raises(ValueError, match="FLUIDNB_MAX_PIXELS must be a positive number"):
        as_image(tmp_path / "small.png")


def test_a_fifo_or_a_folder_is_named_as_what_it_is(tmp_path):
    import os

    os.mkfifo(tmp_path / "pipe.png")  # reading it would wait for a writer forever
    with pytest.raises(ValueError, match=r"image: '.*pipe.png' is a named pipe \(FIFO\), not an"):
        as_image(tmp_path / "pipe.png")
    with pytest.raises(ValueError, match="is a folder, not an image file"):
        as_image(tmp_path)


def test_max_side_averages_areas_down_and_keeps_what_fits(tmp_path):
    from fluidnb._image import shrunk_shape

    assert shrunk_shape((3000, 4000), 1920) == (1440, 1920)
    assert shrunk_shape((1080, 1920), 1920) == (1080, 1920)
    assert shrunk_shape((10, 9000), 1920) == (2, 1920)
    # A checkerboard of 2 x 2 blocks halves to flat blocks of their means: exactly.
    gen = np.random.default_rng(0)
    blocks = gen.integers(0, 256, (6, 8, 3)).astype(np.uint8)
    fine = blocks.repeat(2, axis=0).repeat(2, axis=1)
    fine[::2, ::2] = 0  # one dark pixel in each 2 x 2 block
    expected = fine.reshape(6, 2, 8, 2, 3).astype(np.float64).mean(axis=(1, 3)) / 255
    Image.fromarray(fine).save(tmp_path / "fine.png")
    for source in (tmp_path / "fine.png", fine, Image.open(tmp_path / "fine.png")):
        out = as_image(source, max_side=8)
        assert out.shape == (6, 8, 3)
        np.testing.assert_allclose(out, expected, atol=1 / 255)
    # Images that fit are returned exactly as without max_side.
    np.testing.assert_array_equal(as_image(fine, max_side=16), as_image(fine))
    np.testing.assert_array_equal(as_image(tmp_path / "fine.png", max_side=99), as_image(fine))


def test_max_side_weights_colour_by_alpha(tmp_path):
    # A cut-out: opaque red beside clear pixels whose stored colour is green.
    rgba = np.zeros((2, 4, 4), np.uint8)
    rgba[:, 0::2] = [255, 0, 0, 255]
    rgba[:, 1::2] = [0, 255, 0, 0]
    Image.fromarray(rgba).save(tmp_path / "cut.png")
    for source in (tmp_path / "cut.png", rgba):
        rgb, alpha = as_image(source, max_side=2, return_alpha=True)
        assert rgb.shape == (1, 2, 3)
        np.testing.assert_allclose(alpha, 0.5, atol=1 / 255)
        np.testing.assert_allclose(rgb[..., 0], 1.0, atol=1 / 255)  # no green bleeds in
        np.testing.assert_allclose(rgb[..., 1], 0.0, atol=1 / 255)


def test_a_large_jpeg_is_decoded_small(tmp_path):
    # 4000 x 3000 (12 MP): decoded at 1/2 size by the JPEG decoder, then averaged down.
    y, x = np.mgrid[:3000, :4000]
    ramp = ((x / 4000 * 200) + (y / 3000 * 50)).astype(np.uint8)
    Image.fromarray(ramp).save(tmp_path / "phone.jpg", quality=95)
    out = as_image(tmp_path / "phone.jpg", max_side=1920)
    assert out.shape == (1440, 1920)
    yy, xx = (np.mgrid[:1440, :1920] + 0.5) / 0.48 - 0.5
    want = ((xx / 4000 * 200) + (yy / 3000 * 50)) / 255
    np.testing.assert_allclose(out, want, atol=3 / 255)


@pytest.mark.parametrize("orientation", range(1, 9))
def test_a_phone_photo_is_read_upright(tmp_path, orientation):
    # A phone stores the sensor's pixels and writes which way is up into EXIF tag 0x0112;
    # we show the photo as every viewer does (Pillow's exif_transpose is the reference),
    # whether it is read in full, shrunk on the way in, or uploaded as a PIL image.
    from fluidnb._image import image_size

    rng = np.random.default_rng(orientation)
    stored = rng.integers(0, 256, (30, 40, 3), dtype=np.uint8)
    exif = Image.Exif()
    exif[0x0112] = orientation
    Image.fromarray(stored).save(tmp_path / "phone.png", exif=exif)
    with Image.open(tmp_path / "phone.png") as im:
        want = np.asarray(ImageOps.exif_transpose(im)) / np.float32(255)
    assert want.shape[:2] == ((40, 30) if orientation >= 5 else (30, 40))
    np.testing.assert_array_equal(as_image(tmp_path / "phone.png"), want)
    assert image_size(tmp_path / "phone.png") == want.shape[:2]
    with Image.open(tmp_path / "phone.png") as im:
        np.testing.assert_array_equal(as_image(im), want)
    shrunk = as_image(tmp_path / "phone.png", max_side=20)
    assert shrunk.shape[:2] == ((20, 15) if orientation >= 5 else (15, 20))
    # the shrink averages 2 x 2 blocks of the upright photo: same blocks, same pixels
    blocks = want.reshape(want.shape[0] // 2, 2, want.shape[1] // 2, 2, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(shrunk, blocks, atol=1.5 / 255)  # 8-bit rounding of a mean
