"""Bad input a new user gives: one ValueError that names the input and what is allowed.

Each of these used to fail with a message about something else (numpy's gradient, the
photo instead of its matte, "velocity must not be empty") or not at all.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from fluidnb import data, to_uint8
from fluidnb.cli import main
from fluidnb.sketch import check_strokes, direction_field, load_strokes, save_strokes

# ---------------------------------------------------------------------- frost


@pytest.mark.parametrize("shape", [(1, 1), (1, 6), (6, 1)])
def test_frost_on_a_photo_too_small_names_it_and_the_minimum(shape):
    from fluidnb.frost import FrostParams, frost

    image = np.full((*shape, 3), 0.5, np.float32)
    h, w = shape
    with pytest.raises(ValueError, match=rf"image is {h} x {w} pixels; frost needs at least 2 x 2"):
        frost(image, np.ones(shape, bool), [(0, 0)], FrostParams(spacing=1), seed=0)


def test_frost_renders_the_smallest_photo_it_accepts():
    from fluidnb.frost import FrostParams, frost

    clip = frost(np.full((2, 2, 3), 0.5), np.ones((2, 2), bool), [(0, 0)], FrostParams(spacing=1))
    assert clip.shape == (2, 2)


def test_frost_size_keeps_two_pixels_across_a_thin_photo():
    from fluidnb.frost import FrostParams, HexLattice, grow, render

    lattice = HexLattice.from_mask(np.ones((2, 300), bool), 2.0)
    result = grow(lattice, [0], FrostParams(spacing=2, beta=0.6), seed=0)
    clip = render(None, lattice, result, size=8, every=50)
    assert clip.shape == (2, 8)


def test_frost_command_names_the_photo(tmp_path, capsys):
    Image.fromarray(np.zeros((1, 1, 3), np.uint8)).save(tmp_path / "tiny.png")
    argv = ["frost", str(tmp_path / "tiny.png"), "--start", "0,0", "-o", str(tmp_path / "f.gif")]
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "IMAGE" in err
    assert "tiny.png' is 1 x 1 pixels; frost needs at least 2 x 2" in err


# ---------------------------------------------------------------------- fire


@pytest.fixture(scope="module")
def fire_photo():
    return data.sample("fire", size=40, return_alpha=True)


def test_fire_with_an_empty_matte_says_the_matte_has_no_flame(fire_photo):
    from fluidnb.fire import fire

    photo, _ = fire_photo
    with pytest.raises(ValueError, match=r"^matte has no flame region: it is 0 \(black\)"):
        fire(photo, None, matte=np.zeros(photo.shape[:2]), n_frames=2, seed=0)


def test_fire_with_a_transparent_cut_out_says_its_alpha_is_empty(fire_photo):
    from fluidnb.fire import fire

    photo, _ = fire_photo
    rgba = np.dstack([photo, np.zeros(photo.shape[:2], np.float32)])
    with pytest.raises(ValueError, match=r"^photo's alpha channel \(its matte\) has no flame"):
        fire(rgba, None, n_frames=2, seed=0)


def test_fire_command_names_the_matte_file(fire_photo, tmp_path, capsys):
    photo, _ = fire_photo
    Image.fromarray(to_uint8(photo)).save(tmp_path / "photo.png")
    Image.fromarray(np.zeros(photo.shape[:2], np.uint8)).save(tmp_path / "matte.png")
    rgba = np.dstack([to_uint8(photo), np.zeros(photo.shape[:2], np.uint8)])
    Image.fromarray(rgba).save(tmp_path / "clear.png")
    out = str(tmp_path / "o.gif")
    assert (
        main(
            ["fire", str(tmp_path / "photo.png"), "--matte", str(tmp_path / "matte.png"), "-o", out]
        )
        == 2
    )
    assert "--matte" in capsys.readouterr().err
    assert main(["fire", str(tmp_path / "clear.png"), "-o", out]) == 2
    err = capsys.readouterr().err
    assert "alpha channel of PHOTO" in err
    assert "no flame region" in err


# ---------------------------------------------------------------------- turbulence


def _flow_file(path, frames, shape, dx):
    meta = json.dumps({"format": "fluidnb.turbulence.Flow/1", "dx": dx})
    np.savez(
        path,
        velocity=np.zeros((frames, *shape, 2), np.float32),
        density=np.zeros((frames, *shape), np.float32),
        metadata=np.array(meta),
    )
    return path


def test_a_flow_with_no_frames_says_frames():
    from fluidnb.turbulence import Flow

    with pytest.raises(ValueError, match="a flow needs at least one frame: velocity has 0 frames"):
        Flow(np.zeros((0, 8, 8, 2)), np.zeros((0, 8, 8)), 1.0)
    with pytest.raises(ValueError, match="velocity must not be empty"):
        Flow(np.zeros((2, 0, 8, 2)), np.zeros((2, 0, 8)), 1.0)


def test_turbulence_command_says_target_or_source_and_frames(tmp_path, capsys):
    empty = _flow_file(tmp_path / "empty.npz", 0, (6, 4), 1.0)
    full = _flow_file(tmp_path / "full.npz", 2, (48, 32), 0.125)
    for option, target, source in (("--target", empty, full), ("--source", full, empty)):
        argv = ["turbulence", "--target", str(target), "--source", str(source)]
        assert main([*argv, "-o", str(tmp_path / "o.npz")]) == 2
        err = capsys.readouterr().err
        assert f"error: {option}: path '{empty}'" in err
        assert "at least one frame" in err


def test_a_file_that_is_no_archive_is_not_called_pickled_data(tmp_path):
    from fluidnb.turbulence import Flow

    (tmp_path / "junk.npz").write_bytes(b"not an archive")
    with pytest.raises(
        ValueError, match=r"junk\.npz' is not a saved Flow.*not an \.npz archive"
    ) as info:
        Flow.load(tmp_path / "junk.npz")
    assert "pickle" not in str(info.value)


# ---------------------------------------------------------------------- strokes


def test_strokes_far_outside_the_image_are_refused_at_every_boundary(tmp_path):
    far = [[[10, 5], [10, 100]]]  # a 20 x 30 image: column 100 is > 30 px beyond its border
    with pytest.raises(ValueError, match=r"strokes\[0\] has a point at \(row, col\) = \(10, 100\)"):
        save_strokes(tmp_path / "s.json", far, (20, 30))
    assert not (tmp_path / "s.json").exists()
    with pytest.raises(ValueError, match="far outside the 20 x 30 image"):
        direction_field(far, (20, 30))
    (tmp_path / "far.json").write_text(
        json.dumps({"format": "fluidnb.strokes", "version": 1, "shape": [20, 30], "strokes": far})
    )
    with pytest.raises(ValueError, match=r"far\.json'.*far outside"):
        load_strokes(tmp_path / "far.json")


def test_points_just_outside_the_image_are_kept():
    """A hand drawing to the border goes a little past it; up to an image size is fine."""
    h, w = 20, 30
    edge = [[[-h, -w], [2 * h - 1, 2 * w - 1]]]
    assert check_strokes(edge, (h, w))[0].tolist() == [[-20.0, -30.0], [39.0, 59.0]]
    assert direction_field([[[10, -3], [10, 33]]], (h, w)).shape == (h, w, 2)
    with pytest.raises(ValueError, match="far outside"):
        check_strokes([[[-h - 0.5, 0], [0, 5]]], (h, w))


def test_an_empty_stroke_list_is_refused_where_it_enters(tmp_path):
    with pytest.raises(ValueError, match="strokes is empty: draw at least one stroke"):
        save_strokes(tmp_path / "s.json", [], (20, 30))
    with pytest.raises(ValueError, match="strokes is empty"):
        direction_field([], (20, 30))
    (tmp_path / "empty.json").write_text(
        json.dumps({"format": "fluidnb.strokes", "version": 1, "shape": [20, 30], "strokes": []})
    )
    with pytest.raises(ValueError, match=r"empty\.json': strokes is empty"):
        load_strokes(tmp_path / "empty.json")


def test_animate_refuses_empty_strokes_before_it_opens_the_database(tmp_path, capsys):
    """Not after minutes of building a starter database: --db here does not even exist."""
    Image.fromarray(np.zeros((20, 30, 3), np.uint8)).save(tmp_path / "p.png")
    (tmp_path / "empty.json").write_text(
        json.dumps({"format": "fluidnb.strokes", "version": 1, "shape": [20, 30], "strokes": []})
    )
    argv = ["animate", str(tmp_path / "p.png"), "--strokes", str(tmp_path / "empty.json")]
    assert main([*argv, "--db", str(tmp_path / "no-db"), "-o", str(tmp_path / "o.gif")]) == 2
    assert "strokes is empty" in capsys.readouterr().err
