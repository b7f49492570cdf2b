import json
import re

import numpy as np
import pytest
from PIL import Image

from fluidnb import data

ALL = data.names()
CATALOGUE = {e["name"]: e for e in data.catalogue()}
PHOTOS = [n for n in ALL if CATALOGUE[n]["kind"] == "photo"]
PROCEDURAL = [n for n in ALL if CATALOGUE[n]["kind"] == "procedural"]
IMAGE_SUFFIXES = {".png", ".jpg", ".jpeg", ".gif", ".webp", ".tif", ".tiff", ".bmp"}
METHODS = {"flicker", "frost", "fire", "turbulence", "videodb", "any"}


def _records():
    with open(data.data_dir() / "sources.json", encoding="utf-8") as f:
        return json.load(f)["photos"]


def test_there_are_photos_and_procedural_samples_for_every_method():
    assert len(PHOTOS) >= 4
    assert len(PROCEDURAL) >= 4
    assert len(set(ALL)) == len(ALL)
    suited = {m for e in CATALOGUE.values() for m in e["methods"]}
    assert suited <= METHODS
    assert {"flicker", "frost", "fire", "videodb"} <= suited
    photo_methods = {m for n in PHOTOS for m in CATALOGUE[n]["methods"]}
    assert {"flicker", "frost", "fire", "videodb"} <= photo_methods


@pytest.mark.parametrize("name", ALL)
def test_every_sample_loads_as_float32_01_with_documented_shape(name):
    entry = CATALOGUE[name]
    image, alpha = data.sample(name, return_alpha=True)
    assert image.dtype == np.float32
    assert image.shape == tuple(entry["shape"])
    assert image.flags.c_contiguous
    assert np.all(np.isfinite(image))
    assert image.min() >= 0.0
    assert image.max() <= 1.0
    assert image.max() - image.min() > 0.2  # not blank
    if entry["has_alpha"]:
        assert alpha.dtype == np.float32
        assert alpha.shape == image.shape[:2]
        assert 0.0 <= alpha.min() < 0.05
        assert 0.95 < alpha.max() <= 1.0
    else:
        assert alpha is None
    # Without return_alpha just the image.
    assert isinstance(data.sample(name), np.ndarray)


@pytest.mark.parametrize("name", ALL)
def test_catalogue_entries_are_complete(name):
    entry = CATALOGUE[name]
    for key in ("name", "kind", "description", "methods", "source", "author", "licence"):
        assert entry[key], key
    assert entry["kind"] in ("photo", "procedural")
    assert isinstance(entry["methods"], list)


def test_catalogue_is_a_fresh_copy():
    first = data.catalogue()
    first[0]["name"] = "changed"
    first[0]["methods"].append("changed")
    again = data.catalogue()
    assert again[0]["name"] == ALL[0]
    assert "changed" not in again[0]["methods"]


@pytest.mark.parametrize("name", PROCEDURAL)
def test_procedural_samples_are_deterministic(name):
    a1, m1 = data.sample(name, size=40, return_alpha=True)
    a2, m2 = data.sample(name, size=40, return_alpha=True)
    assert np.array_equal(a1, a2)
    assert a1 is not a2
    if m1 is not None:
        assert np.array_equal(m1, m2)


@pytest.mark.parametrize("name", ALL)
def test_size_as_longest_side_and_as_height_width(name):
    h, w = CATALOGUE[name]["shape"][:2]
    image, alpha = data.sample(name, size=50, return_alpha=True)
    assert max(image.shape[:2]) == 50
    assert image.shape[0] == max(1, round(h * 50 / max(h, w)))
    assert image.shape[1] == max(1, round(w * 50 / max(h, w)))
    assert image.shape[2:] == tuple(CATALOGUE[name]["shape"][2:])
    if alpha is not None:
        assert alpha.shape == image.shape[:2]
    exact = data.sample(name, size=(17, 23))
    assert exact.shape[:2] == (17, 23)
    assert exact.dtype == np.float32
    assert 0.0 <= exact.min() <= exact.max() <= 1.0
    big = data.sample(name, size=(h + 7, w + 5))  # enlarging works too
    assert big.shape[:2] == (h + 7, w + 5)


def test_shrinking_a_photo_is_anti_aliased():
    # A shrunk photo matches a box-filtered (area-averaged) one far better than
    # every n-th pixel would.
    full = data.sample("stream")
    small = data.sample("stream", size=(full.shape[0] // 4, full.shape[1] // 4))
    h, w = small.shape[:2]
    boxed = full[: 4 * h, : 4 * w].reshape(h, 4, w, 4, 3).mean(axis=(1, 3))
    decimated = full[: 4 * h : 4, : 4 * w : 4]
    assert np.abs(small - boxed).mean() < 0.5 * np.abs(decimated - boxed).mean()


def test_procedural_picture_scales_with_size():
    # Same picture at two sizes: the smaller one matches the larger one shrunk.
    big = data.sample("ripples", size=128)
    small = data.sample("ripples", size=64)
    shrunk = big.reshape(64, 2, 64, 2, 3).mean(axis=(1, 3))
    assert np.abs(small - shrunk).mean() < 0.03


def test_mode_grey_and_rgb():
    grey = data.sample("stream", mode="grey")
    assert grey.shape == tuple(CATALOGUE["stream"]["shape"][:2])
    rgb = data.sample("checker", mode="rgb", size=(8, 8))
    assert rgb.shape == (8, 8, 3)
    assert np.array_equal(rgb[..., 0], rgb[..., 2])
    with pytest.raises(ValueError, match="mode must be one of"):
        data.sample("checker", mode="colour")


def test_checker_pattern():
    c = data.sample("checker", size=(8, 8))
    assert c.tolist()[0][:3] == [1.0, 0.0, 1.0]
    assert np.array_equal(c, c.T)
    assert c.sum() == 32


def test_samples_with_alpha_are_flames_over_black():
    for name in ("fire", "flame"):
        image, alpha = data.sample(name, return_alpha=True)
        outside = alpha < 0.01
        assert outside.mean() > 0.2
        assert image[outside].max() < 0.1  # dark background
        inside = alpha > 0.99
        assert image[inside].mean() > 0.5  # bright flame
        red, blue = image[inside][:, 0].mean(), image[inside][:, 2].mean()
        assert red > blue  # warm colours


def test_results_are_new_arrays():
    a = data.sample("leaf")
    a[:] = 0
    assert data.sample("leaf").max() > 0


def test_unknown_name_lists_the_available_ones():
    with pytest.raises(ValueError, match="unknown sample 'nope'") as info:
        data.sample("nope")
    for name in ALL:
        assert name in str(info.value)
    with pytest.raises(ValueError, match="available samples"):
        data.path("nope")
    with pytest.raises(ValueError, match="unknown sample"):
        data.sample(3)


@pytest.mark.parametrize("size", [0, -3, 2.5, True, "big", (10,), (0, 5), (5, 1.5), 100000])
def test_bad_size_is_refused(size):
    with pytest.raises(ValueError, match=re.escape("size")):
        data.sample("checker", size=size)


def test_path_of_photos_and_not_of_procedural():
    for name in PHOTOS:
        p = data.path(name)
        assert p.is_file()
        assert p.parent == data.data_dir()
        assert p.name == CATALOGUE[name]["file"]
    with pytest.raises(ValueError, match="procedural"):
        data.path("checker")


def test_every_photo_record_has_an_existing_file_and_a_licence():
    records = _records()
    assert [r["name"] for r in records] == PHOTOS
    for r in records:
        assert (data.data_dir() / r["file"]).is_file(), r["file"]
        for key in (
            "author",
            "licence",
            "licence_url",
            "source",
            "source_url",
            "modifications",
            "description",
            "debian_package",
            "original_path",
        ):
            assert isinstance(r[key], str), (r["name"], key)
            assert r[key].strip(), (r["name"], key)
        with Image.open(data.data_dir() / r["file"]) as im:
            assert (im.height, im.width) == tuple(r["shape"][:2])
            assert ("A" in im.getbands()) == r["has_alpha"]


def test_every_image_file_is_listed_with_a_licence():
    listed = {r["file"] for r in _records()}
    images = {p.name for p in data.data_dir().iterdir() if p.suffix.lower() in IMAGE_SUFFIXES}
    assert images == listed, f"image files without a licence record: {images - listed}"
    sources_md = (data.data_dir() / "SOURCES.md").read_text(encoding="utf-8")
    for r in _records():
        assert f"`{r['file']}`" in sources_md
        assert r["author"].split("<")[0].strip().strip('"') in sources_md


def test_folder_stays_small():
    files = [p for p in data.data_dir().rglob("*") if p.is_file() and "__pycache__" not in p.parts]
    total = sum(p.stat().st_size for p in files)
    assert total < 2 * 1024 * 1024, total
    for p in files:
        if p.suffix.lower() in IMAGE_SUFFIXES:
            assert p.stat().st_size < 150 * 1024, p.name


def test_data_dir_holds_the_records():
    d = data.data_dir()
    assert d.is_absolute()
    assert (d / "sources.json").is_file()
    assert (d / "SOURCES.md").is_file()


def test_stream_region_covers_the_water_and_not_the_rocks():
    photo = data.sample("stream")
    matte = data.region("stream")
    assert matte.shape == photo.shape[:2]
    assert matte.dtype == np.float32
    assert matte.min() == 0.0
    assert matte.max() == pytest.approx(1.0)
    # Hand-checked points of the 480 x 376 photo, (row, col): water of the cascade and
    # of the pool; the big rock on the right and the moss at the top left.
    for r, c in [(120, 230), (250, 200), (350, 100)]:
        assert matte[r, c] == pytest.approx(1.0), (r, c)
    for r, c in [(200, 400), (20, 20), (300, 440)]:
        assert matte[r, c] == 0.0, (r, c)
    # A soft edge: values strictly between 0 and 1 along the outline only.
    edge = (matte > 0.02) & (matte < 0.98)
    assert 0 < edge.mean() < 0.08  # the outline is ~1,300 px long, the edge ~5 px wide


def test_clouds_region_covers_the_cloud_and_not_the_sky_or_the_rocks():
    matte = data.region("clouds")
    assert matte.shape == data.sample("clouds").shape[:2]
    for r, c in [(150, 150), (200, 250), (140, 320), (90, 100)]:  # cloud, wisps
        assert matte[r, c] > 0.999, (r, c)
    for r, c in [(20, 240), (60, 420), (280, 60), (200, 420), (100, 250)]:  # sky, rock
        assert matte[r, c] == 0.0, (r, c)


def test_region_follows_the_sample_size():
    for size in (240, (100, 200)):
        matte = data.region("stream", size=size)
        assert matte.shape == data.sample("stream", size=size).shape[:2]
    small, full = data.region("stream", size=240), data.region("stream")
    assert abs(small.mean() - full.mean()) < 0.01


def test_region_of_a_sample_without_one_is_refused():
    with pytest.raises(ValueError, match=r"no drawn region.*stream, clouds"):
        data.region("checker")
    with pytest.raises(ValueError, match="unknown sample"):
        data.region("nope")
