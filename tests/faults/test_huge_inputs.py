"""Absurd or huge inputs run in bounded memory, or are refused at once (issue 37).

200,000 two-point strokes (4 MB of JSON) ran `fluidnb animate` out of memory after
56 s: every stroke gave two tangent samples however far the spacing grew, and the
RBF fit over 400,000 samples needs O(m^2) memory. A 182 KiB PNG of 8000 x 8000 black
pixels ran flicker for 79 s and died of memory under a 4 GiB cap. Each case runs in
a subprocess whose address space is capped, so a regression fails here instead of
taking the machine down.
"""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap

import numpy as np
import pytest

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="RLIMIT_AS as on Linux")

CAPPED = """
import resource, sys
cap = {cap} << 30
resource.setrlimit(resource.RLIMIT_AS, (cap, cap))
sys.argv = ["fluidnb", *{argv!r}]
"""


def _run_capped(code, cap_gib, cwd):
    return subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, check=False, cwd=cwd
    )


def _strokes_file(path, n, shape=(480, 640), seed=0):
    """``n`` strokes of two points, 3 px long, rightwards in the top half, left below."""
    h, w = shape
    gen = np.random.default_rng(seed)
    starts = gen.uniform([0, 0], [h, w - 4], (n, 2)).round(2)
    step = np.where(starts[:, :1] < h / 2, 3.0, -3.0) * np.array([[0.0, 1.0]])
    strokes = np.stack([starts, starts + step], axis=1).clip(0, [h - 1, w - 1])
    data = {"format": "fluidnb.strokes", "version": 1, "shape": [h, w], "strokes": strokes}
    path.write_text(json.dumps({**data, "strokes": strokes.tolist()}))
    return path


def test_200000_short_strokes_make_a_direction_field_in_bounded_memory(tmp_path):
    path = _strokes_file(tmp_path / "many.json", 200_000)
    assert path.stat().st_size > 4e6
    code = CAPPED.format(cap=3, argv=[]) + textwrap.dedent(
        f"""
        import numpy as np
        from fluidnb.sketch import direction_field, load_strokes
        strokes, shape = load_strokes({str(path)!r})
        field = direction_field(strokes, shape)
        top, bottom = field[40:200, :, 1], field[280:440, :, 1]
        print(float(np.median(top)), float(np.median(bottom)), float((top > 0.9).mean()))
        """
    )
    run = _run_capped(code, 3, tmp_path)
    assert run.returncode == 0, run.stderr[-2000:]
    top, bottom, share = (float(x) for x in run.stdout.split())
    assert top > 0.99
    assert bottom < -0.99
    assert share > 0.99


# ---------------------------------------------------------------- photos larger than --max-side


@pytest.fixture(scope="module")
def doubled(tmp_path_factory):
    """make_inputs' files, and every image and strokes file drawn on them at twice the size."""
    from PIL import Image

    from fluidnb.sketch import load_strokes, save_strokes
    from tests.support.cli_inputs import make_inputs

    d = make_inputs(tmp_path_factory.mktemp("doubled"))
    for name in ("photo", "background", "mask", "speed", "fire", "fire-matte"):
        with Image.open(d / f"{name}.png") as im:
            im.resize((im.width * 2, im.height * 2), Image.Resampling.NEAREST).save(
                d / f"{name}-2x.png"
            )
    strokes, (h, w) = load_strokes(d / "strokes.json")
    save_strokes(d / "strokes-2x.json", [(s + 0.5) * 2 - 0.5 for s in strokes], (2 * h, 2 * w))
    return d


def _recipes(d, o):
    """(names, argv at twice the size, the longest side of the original inputs)."""
    from PIL import Image

    from tests.support.cli_inputs import RECIPES, H, W

    with Image.open(d / "fire.png") as im:
        fire_side = max(im.size)
    cases = {}
    for names in (("flicker",), ("frost",), ("fire",), ("animate",)):
        argv = [str(a) for a in RECIPES[names](d, o)]
        for name in ("photo", "background", "mask", "speed", "fire", "fire-matte"):
            argv = [a.replace(f"/{name}.png", f"/{name}-2x.png") for a in argv]
        argv = [a.replace("/strokes.json", "/strokes-2x.json") for a in argv]
        if names == ("frost",):  # X,Y in the photo's pixels: the same place, twice as far
            argv[argv.index("--start") + 1] = "61,49"
        side = fire_side if names == ("fire",) else max(H, W)
        cases[names] = (argv, side)
    return cases


@pytest.mark.parametrize("command", ["flicker", "frost", "fire", "animate"])
def test_a_photo_larger_than_max_side_is_worked_on_smaller_with_a_note(
    doubled, tmp_path, command, capsys
):
    from fluidnb import Clip
    from fluidnb.cli import main
    from fluidnb.sketch import load_strokes

    argv, side = _recipes(doubled, tmp_path)[(command,)]
    assert main([*argv, "--max-side", str(side)]) == 0, capsys.readouterr().err
    err = capsys.readouterr().err
    notes = [line for line in err.splitlines() if ": note: " in line]
    assert len(notes) == 1, err
    assert "working at " in notes[0]
    assert f"--max-side {side};" in notes[0]
    clip = Clip.load(argv[argv.index("-o") + 1])
    meta = clip.metadata["downscaled"]
    assert max(meta["to"]) == side
    assert meta["from"] == [2 * n for n in meta["to"]]
    if command != "fire":  # (fire renders at its own input_size)
        assert clip.shape[:2] == tuple(meta["to"])
    # The strokes were scaled with the photo: the same as drawn on the photo at 1x.
    if command in ("flicker", "animate"):
        small, _ = load_strokes(doubled / "strokes.json")
        big, _ = load_strokes(doubled / "strokes-2x.json")
        from fluidnb.cli._photo import Photo

        photo = Photo(str(doubled / "photo-2x.png"), "photo", side)
        np.testing.assert_allclose(photo.points(big)[0], small[0], atol=1e-9)


def test_max_side_0_keeps_the_full_size_and_hd_is_never_reduced(doubled, tmp_path, capsys):
    from PIL import Image

    from fluidnb import Clip, as_image
    from fluidnb.cli import main
    from fluidnb.cli._photo import MAX_SIDE, Photo

    out = tmp_path / "full.gif"
    argv = ["flicker", str(doubled / "photo-2x.png"), "--mask", str(doubled / "mask-2x.png")]
    assert main([*argv, "--T", "4", "--f0", "1", "--max-side", "0", "-o", str(out)]) == 0
    assert ": note: " not in capsys.readouterr().err
    clip = Clip.load(out)
    assert clip.shape[:2] == (96, 128)
    assert "downscaled" not in clip.metadata
    # HD input (issue 39's size) is worked on as it is.
    Image.new("RGB", (1920, 1080), (40, 90, 160)).save(tmp_path / "hd.png")
    photo = Photo(str(tmp_path / "hd.png"), "IMAGE", MAX_SIDE)
    assert MAX_SIDE == 1920
    assert (photo.scaled, photo.shape, photo.metadata()) == (False, (1080, 1920), {})
    np.testing.assert_array_equal(photo.read(), as_image(tmp_path / "hd.png"))


def test_a_phone_photo_is_decoded_at_the_working_size(tmp_path):
    """A 12 MP JPEG never exists in memory as floats at full size (144 MB)."""
    import tracemalloc

    from PIL import Image

    from fluidnb.cli._photo import Photo

    gen = np.random.default_rng(0)
    small = gen.integers(0, 256, (300, 400, 3), dtype=np.uint8)
    Image.fromarray(small).resize((4000, 3000), Image.Resampling.BILINEAR).save(
        tmp_path / "phone.jpg", quality=90
    )
    photo = Photo(str(tmp_path / "phone.jpg"), "IMAGE", 1920)
    assert photo.shape == (1440, 1920)
    tracemalloc.start()
    try:
        image = photo.read(mode="rgb")
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert image.shape == (1440, 1920, 3)
    assert peak < 3 * image.nbytes  # 33 MB of result; the full size would be 144 MB


def test_a_companion_of_another_size_is_refused_naming_both(doubled, tmp_path, capsys):
    from fluidnb.cli import main

    argv = ["flicker", str(doubled / "photo-2x.png"), "--mask", str(doubled / "mask.png")]
    assert main([*argv, "--max-side", "64", "-o", str(tmp_path / "o.gif")]) == 2
    err = capsys.readouterr().err.strip()
    assert err.startswith("fluidnb flicker: error: --mask must have the same height and width")
    assert "(96, 128)" in err
    assert "(48, 64)" in err
