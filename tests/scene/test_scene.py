"""A scene: several methods on one photo (issue 38) -- compositing, timing, caching, files."""

import json

import numpy as np
import pytest
from scipy import ndimage as ndi

from fluidnb.data import sample
from fluidnb.fire import FireParams
from fluidnb.flicker import FlickerParams
from fluidnb.frost import FrostParams
from fluidnb.scene import (
    SCENE_VERSION,
    Layer,
    LayerClip,
    Scene,
    composite,
    frame_index,
    innermost_point,
    load_scene,
    render,
    save_scene,
    seamless_loop,
    timeline,
)

# Small and quick: every layer in a few seconds on 2 cores.
FLICKER = FlickerParams(T=16, fps=8.0)
FIRE = FireParams(output_size=48, interval=4)
FROST = FrostParams(spacing=3.0, gamma=0.05, target=40, max_frames=60)


@pytest.fixture(scope="module")
def photo():
    return sample("lake", size=96)  # a photo no method was tuned on: 96 x 54


def _box(shape, rows, cols):
    h, w = shape
    m = np.zeros((h, w), bool)
    m[int(rows[0] * h) : int(rows[1] * h), int(cols[0] * w) : int(cols[1] * w)] = True
    return m


@pytest.fixture(scope="module")
def regions(photo):
    shape = photo.shape[:2]
    return {
        "flicker": _box(shape, (0.45, 0.65), (0.0, 1.0)),
        "fire": _box(shape, (0.5, 0.7), (0.7, 0.8)),
        "frost": _box(shape, (0.0, 0.4), (0.0, 0.3)),
    }


@pytest.fixture(scope="module")
def rendered(photo, regions):
    scene = Scene(
        photo,
        [
            Layer("flicker", regions["flicker"], FLICKER),
            Layer("fire", regions["fire"], FIRE, seed=1),
            Layer("frost", regions["frost"], FROST, seed=2),
        ],
        size=None,
    )
    return scene, render(scene)


# ---------------------------------------------------------------- held-out checks
def test_outside_every_region_each_frame_is_the_photo(photo, regions, rendered):
    _, clip = rendered
    anywhere = regions["flicker"] | regions["frost"]
    # The fire's glow reaches a little beyond its region: a margin of its size.
    anywhere |= ndi.binary_dilation(regions["fire"], iterations=12)
    outside = ~anywhere
    assert outside.sum() > 0.2 * outside.size
    for frame in clip.frames:
        assert np.array_equal(frame[outside], photo[outside])


def test_each_layer_does_what_its_method_does(photo, regions, rendered):
    _, clip = rendered
    f = clip.frames
    # Flicker: the water's brightness changes from frame to frame.
    water = regions["flicker"]
    assert np.abs(f[1:, water] - f[:-1, water]).mean() > 1e-3
    # Frost grows: ever more of its region differs from the photo, and it holds.
    frost = regions["frost"]
    covered = [(np.abs(fr[frost] - photo[frost]).max(axis=-1) > 0.05).mean() for fr in f]
    assert covered[0] < 0.05 < covered[-1]
    assert np.all(np.diff(covered) > -0.02)
    # Fire adds light: its region is brighter than the photo, and it flickers.
    fire = regions["fire"]
    gain = [float((fr[fire] - photo[fire]).mean()) for fr in f]
    assert min(gain) >= 0
    assert np.mean(gain) > 0.02
    assert np.std(gain) > 1e-3


def test_clip_metadata_names_every_layer_and_the_scene_length(rendered):
    scene, clip = rendered
    layers = clip.metadata["layers"]
    assert [x["name"] for x in layers] == ["flicker", "fire", "frost"]
    assert clip.fps == scene.fps == 24.0
    longest = max(x["frames"] / x["fps"] for x in layers)
    assert len(clip) == int(np.ceil(longest * 24 - 1e-9))


# ---------------------------------------------------------------- caching
def test_changing_one_layer_re_renders_only_that_layer(photo, regions):
    scene = Scene(
        photo,
        [Layer("flicker", regions["flicker"], FLICKER), Layer("frost", regions["frost"], FROST)],
        size=None,
    )
    first = render(scene)
    assert scene.renders == 2
    again = render(scene)
    assert scene.renders == 2  # nothing changed: both from the cache
    assert np.array_equal(first.frames, again.frames)
    assert [x["seconds"] for x in again.metadata["layers"]] == ["cached", "cached"]
    scene.update("flicker", params=FLICKER.replace(kappa=0.5))
    changed = render(scene)
    assert scene.renders == 3
    assert [x["seconds"] == "cached" for x in changed.metadata["layers"]] == [False, True]
    assert not np.array_equal(first.frames, changed.frames)


def test_a_hidden_layer_is_kept_but_not_rendered(photo, regions):
    scene = Scene(photo, [Layer("flicker", regions["flicker"], FLICKER, visible=False)], size=None)
    with pytest.raises(ValueError, match="no visible layer"):
        render(scene)
    scene.add(Layer("frost", regions["frost"], FROST))
    clip = render(scene)
    assert [x["name"] for x in clip.metadata["layers"]] == ["frost"]
    assert np.array_equal(clip.frames[-1][regions["flicker"]], scene.photo[regions["flicker"]])


# ---------------------------------------------------------------- compositing, exact
def _layer(colour, alpha, fps=24.0, loops=True):
    colour = np.asarray(colour, np.float32)
    return LayerClip(colour, np.asarray(alpha, np.float32), fps, loops, None)


def test_replace_cover_and_light_follow_their_formulas():
    rng = np.random.default_rng(0)
    base = rng.random((4, 5, 3), dtype=np.float32) * 0.5
    c = rng.random((1, 4, 5, 3), dtype=np.float32) * 0.5
    a = rng.random((1, 4, 5), dtype=np.float32)
    idx = [np.zeros(1, int)]
    out = composite(base, [_layer(c, a)], ["replace"], idx, 0)
    np.testing.assert_allclose(
        out, (1 - a[0, ..., None]) * base + a[0, ..., None] * c[0], atol=1e-6
    )
    out = composite(base, [_layer(c * a[..., None], a)], ["cover"], idx, 0)
    np.testing.assert_allclose(
        out, (1 - a[0, ..., None]) * base + a[0, ..., None] * c[0], atol=1e-6
    )
    out = composite(base, [_layer(c, a)], ["light"], idx, 0)
    np.testing.assert_allclose(out, base + a[0, ..., None] * c[0], atol=1e-6)
    # Light saturates at white; nothing leaves [0, 1].
    bright = composite(
        np.full((4, 5, 3), 0.9, np.float32), [_layer(c + 0.5, a * 0 + 1)], ["light"], idx, 0
    )
    assert bright.max() == 1.0
    # Where a layer's weight is 0 (and light black), the picture is untouched, bit for bit.
    zero = composite(base, [_layer(c, a * 0)], ["replace"], idx, 0)
    assert np.array_equal(zero, base)
    # Order matters: water over fire hides the fire's light where it replaces.
    full = np.ones((1, 4, 5), np.float32)
    water, fire = _layer(c, full), _layer(c + 0.3, full)
    top = composite(base, [fire, water], ["light", "replace"], idx * 2, 0)
    np.testing.assert_allclose(top, c[0], atol=1e-6)
    with pytest.raises(ValueError, match="blend"):
        composite(base, [water], ["multiply"], idx, 0)


def test_loops_repeat_and_growth_holds_its_last_frame():
    loop = _layer(np.zeros((6, 1, 1, 3)), np.zeros((1, 1)), fps=12.0, loops=True)
    grow = _layer(np.zeros((10, 1, 1, 3)), np.zeros((1, 1)), fps=24.0, loops=False)
    n, (a, b) = timeline([loop, grow], 24.0)
    assert n == 12  # the loop's 0.5 s and the growth's 10 frames: the longer, 0.5 s
    assert a.tolist() == [0, 0, 1, 1, 2, 2, 3, 3, 4, 4, 5, 5]
    assert b.tolist() == [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 9, 9]
    n, (a, _) = timeline([loop, grow], 24.0, duration=1.0)
    assert n == 24
    assert a[12:].tolist() == a[:12].tolist()  # the loop repeats
    assert frame_index(np.arange(3), 8.0, grow).tolist() == [0, 3, 6]


def test_seamless_loop_fades_the_end_into_the_start():
    rng = np.random.default_rng(3)
    f = rng.random((20, 3, 3), dtype=np.float32)
    out = seamless_loop(f, 5)
    assert len(out) == 15
    assert np.array_equal(out[5:], f[5:15])  # untouched after the fade
    # The step from the last frame back to the first is as small as an ordinary step
    # into the fade (frame 0 is mostly f[15], which followed f[14]).
    w = 1 / 6
    np.testing.assert_allclose(out[0], w * f[0] + (1 - w) * f[15], atol=1e-6)
    with pytest.raises(ValueError, match="k must be"):
        seamless_loop(f, 20)


def test_frost_starts_at_the_regions_innermost_point():
    m = np.zeros((30, 40), bool)
    m[5:25, 10:20] = True
    r, c = innermost_point(m)[0]
    assert 13 <= r <= 16
    assert 14 <= c <= 15


# ---------------------------------------------------------------- the video database
def test_water_from_the_video_database_moves_and_stays_in_reach(photo, regions, monkeypatch):
    monkeypatch.setenv("FLUIDNB_QUICK", "1")  # the quick starter database, cached
    water = _box(photo.shape[:2], (0.45, 0.7), (0.0, 1.0))
    scene = Scene(photo, [Layer("water", water, strokes=[[[40, 5], [40, 90]]])], size=None)
    clip = render(scene)
    f = clip.frames
    assert np.abs(f[1:, water] - f[:-1, water]).mean() > 1e-3  # the water moves
    far = ~ndi.binary_dilation(water, iterations=12)
    assert all(np.array_equal(fr[far], photo[far]) for fr in f)


# ---------------------------------------------------------------- scene files
def test_a_scene_file_round_trips(tmp_path, photo, regions):
    soft = ndi.gaussian_filter(regions["flicker"].astype(np.float32), 2)
    speed = np.zeros(photo.shape[:2], np.float32)
    speed[30:, :] = 2.5
    scene = Scene(
        photo,
        [
            Layer("water", soft, strokes=[[[40, 5], [40, 90]]], speed=speed, name="lake"),
            Layer("fire", regions["fire"], FIRE, seed=4),
            Layer("frost", regions["frost"], FROST, starts=[[5, 5]], visible=False),
        ],
        size=None,
        fps=12.0,
        duration=2.0,
    )
    folder = save_scene(scene, tmp_path / "s")
    back = load_scene(folder)
    assert (back.fps, back.duration, back.shape) == (12.0, 2.0, scene.shape)
    assert np.abs(back.photo - scene.photo).max() <= 0.5 / 255 + 1e-6
    for a, b in zip(scene.layers, back.layers):
        assert (a.name, a.kind, a.params, a.seed, a.visible) == (
            b.name,
            b.kind,
            b.params,
            b.seed,
            b.visible,
        )
        assert np.abs(a.region - b.region).max() <= 0.5 / 255 + 1e-6
        assert [s.tolist() for s in a.strokes] == [s.tolist() for s in b.strokes]
    np.testing.assert_allclose(back.layers[0].speed, speed, atol=2.5 / 65535)
    assert back.layers[2].starts.tolist() == [[5.0, 5.0]]
    # A bool region comes back exactly: the same cache key, the same clip.
    assert back.layers[1].key(back.photo_key, back.shape) != ""
    assert np.array_equal(back.layers[1].region, scene.layers[1].region)


def _saved(tmp_path, photo, regions):
    scene = Scene(photo, [Layer("flicker", regions["flicker"], FLICKER, name="sea")], size=None)
    folder = save_scene(scene, tmp_path / "s")
    return folder, json.loads((folder / "scene.json").read_text())


@pytest.mark.parametrize(
    ("change", "message"),
    [
        (lambda d, f: d.update(version=SCENE_VERSION + 1), "version 2; this fluidnb reads 1 to 1"),
        (lambda d, f: d.update(format="other"), "is not a fluidnb scene"),
        (lambda d, f: d["layers"][0].update(kind="lava"), "layer 'sea': kind must be one of"),
        (lambda d, f: d["layers"][0].update(params={"T": 3}), "layer 'sea': "),
        (lambda d, f: d["layers"][0].update(params={"nope": 1}), "layer 'sea': .*nope"),
        (
            lambda d, f: (f / "sea.region.png").unlink(),
            "layer 'sea': region file 'sea.region.png' is missing",
        ),
        (
            lambda d, f: d["layers"][0].update(region="../x.png"),
            "region must be a file name in the scene folder",
        ),
        (
            lambda d, f: (f / "sea.region.png").write_bytes(b"not a png"),
            "layer 'sea': region file .* cannot be read",
        ),
        (lambda d, f: d["layers"][0].update(strokes=[[[1, 2, 3]]]), "layer 'sea': "),
        (lambda d, f: d.update(layers={}), "layers must be a list"),
    ],
)
def test_bad_scene_files_get_one_line_naming_the_layer_and_field(
    tmp_path, photo, regions, change, message
):
    folder, data = _saved(tmp_path, photo, regions)
    change(data, folder)
    (folder / "scene.json").write_text(json.dumps(data))
    with pytest.raises(ValueError, match=message) as err:
        load_scene(folder)
    assert "\n" not in str(err.value)


def test_corrupt_and_missing_scene_json(tmp_path):
    with pytest.raises(ValueError, match=r"has no scene\.json"):
        load_scene(tmp_path)
    (tmp_path / "scene.json").write_text("{" * 100_000)
    with pytest.raises(ValueError, match="scene file"):
        load_scene(tmp_path)


# ---------------------------------------------------------------- bad input
def test_layers_refuse_bad_input_naming_the_field(photo, regions):
    with pytest.raises(ValueError, match="kind must be one of"):
        Layer("lava", regions["fire"])
    with pytest.raises(ValueError, match="region is empty"):
        Layer("fire", np.zeros((5, 5)))
    with pytest.raises(ValueError, match=r"region must lie in \[0, 1\]"):
        Layer("fire", np.full((5, 5), 2.0))
    with pytest.raises(ValueError, match="region"):
        Layer("fire", np.full((5, 5), np.nan))
    with pytest.raises(ValueError, match="each stroke"):
        Layer("water", regions["fire"], strokes=[[[1, 2, 3], [4, 5, 6]]])
    with pytest.raises(ValueError, match="speed must have the region's shape"):
        Layer("water", regions["fire"], speed=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="params must be a parameter object"):
        Layer("fire", regions["fire"], params={"weight": 1})
    scene = Scene(photo, [Layer("fire", regions["fire"])], size=None)
    with pytest.raises(ValueError, match="already in the scene"):
        scene.add(Layer("fire", regions["fire"]))
    with pytest.raises(ValueError, match="no layer named 'sky'"):
        scene.update("sky", seed=1)


def test_a_region_of_another_size_is_scaled_with_its_points(photo):
    big = np.zeros((108, 192), bool)  # twice the photo's size
    big[60:100, 20:60] = True
    scene = Scene(photo, size=None)
    layer = scene.add(Layer("frost", big, starts=[[80, 40]]))
    assert layer.region.shape == scene.shape
    assert layer.starts.tolist() == [[40.0, 20.0]]


# ---------------------------------------------------------------- streams (issue 39)
def test_a_streamed_scene_writes_the_frames_of_the_clip(tmp_path, photo, regions, monkeypatch):
    # render(stream=True) makes each layer's frames as they are composited (at HD a
    # file holds a few frames of each layer, not their clips): the same frames, for
    # every kind of layer, a loop shorter than the scene made again from its start.
    from fluidnb import Clip, FrameStream

    monkeypatch.setenv("FLUIDNB_QUICK", "1")  # the quick starter database, cached
    water = _box(photo.shape[:2], (0.7, 1.0), (0.0, 1.0))
    scene = Scene(
        photo,
        [
            Layer("water", water, strokes=[[[80, 5], [80, 90]]]),
            Layer("flicker", regions["flicker"], FLICKER),
            Layer("fire", regions["fire"], FIRE, seed=1),
            Layer("frost", regions["frost"], FROST, seed=2),
        ],
        size=None,
        fps=12.0,
    )
    stream = render(scene, stream=True)
    assert isinstance(stream, FrameStream)
    assert scene.renders == 4
    assert not scene.cache  # a stream neither uses nor fills the cache
    path = stream.save(tmp_path / "scene.npz")
    clip = render(scene)
    assert len(clip) == len(stream)
    # The flicker loop (2 s) is shorter than the scene: it is shown more than once.
    flicker = next(x for x in clip.metadata["layers"] if x["kind"] == "flicker")
    assert len(clip) / clip.fps > 1.5 * flicker["frames"] / flicker["fps"]
    saved = Clip.load(path)
    assert np.array_equal(saved.frames, clip.frames)
    assert saved.metadata["layers"] == [
        {**x, "seconds": y["seconds"]}
        for x, y in zip(clip.metadata["layers"], saved.metadata["layers"])
    ]
    # A second pass makes the same frames again.
    assert np.array_equal(stream.clip().frames, clip.frames)


def test_the_default_frost_is_the_same_lattice_at_any_size():
    # A 3-px lattice is for a 480-px scene; at 1920 px it had 16 times the cells and
    # the default target of 96 frames could not be reached ("target must be >= 106
    # frames"). Scaled with the scene, the growth lasts about its target (96 frames;
    # gamma is fitted to it) at both sizes.
    from fluidnb.scene import run_layer

    lengths = []
    for w in (480, 1920):
        h = w * 9 // 16
        yy, xx = np.mgrid[0:h, 0:w]
        corner = (yy / (0.45 * h)) ** 2 + (xx / (0.30 * w)) ** 2 < 1
        photo = np.full((h, w, 3), 0.4, np.float32)
        lengths.append(len(run_layer(Layer("frost", corner, seed=1), photo, stream=True)))
    assert all(0.8 * 96 <= n <= 1.2 * 96 for n in lengths), lengths


# ---------------------------------------------------------------- a proxy at full size (issue 39)
def _layers_at(shape):
    """Layers of every geometry (region, strokes, starts, speed) in ``shape``'s pixels."""
    h, w = shape
    speed = np.zeros(shape, np.float32)
    speed[int(0.7 * h) :, : w // 2] = 2.5
    flow = [[0.8 * h, 5], [0.85 * h, w - 5]]
    return [
        Layer("water", _box(shape, (0.7, 1.0), (0.0, 1.0)), strokes=[flow], speed=speed),
        Layer("flicker", _box(shape, (0.45, 0.65), (0.0, 1.0)), FLICKER),
        Layer("frost", _box(shape, (0.0, 0.4), (0.0, 0.3)), FROST, starts=[[0.1 * h, 0.1 * w]],
              seed=2),
    ]  # fmt: skip


def test_a_proxy_resized_to_full_size_is_the_scene_built_at_full_size():
    # A scene worked on at a small size (a proxy: the app's previews) is rendered at
    # the photo's full size by scene.resized(): every layer as it was given, so what
    # was painted at full size comes back exactly, not enlarged from the proxy.
    photo = sample("lake", size=192)  # 108 x 192
    full = Scene(photo, _layers_at(photo.shape[:2]), size=None)
    proxy = Scene(photo, _layers_at(photo.shape[:2]), size=64)
    assert proxy.shape == (36, 64)
    assert proxy.full_shape == full.shape == (108, 192)
    assert all(x.region.shape == (36, 64) for x in proxy.layers)
    water = proxy.layer("water")
    assert water.strokes[0][0].tolist() == pytest.approx([0.8 * 108 / 3, 5 / 3], rel=1e-6)
    assert float(water.speed.max()) == pytest.approx(2.5 / 3)  # px/frame scale with the picture
    back = proxy.resized()
    assert back.shape == full.shape
    assert np.array_equal(back.photo, full.photo)
    assert back.photo_key == full.photo_key
    for a, b in zip(back.layers, full.layers, strict=True):
        assert (a.name, a.kind, a.params, a.seed) == (b.name, b.kind, b.params, b.seed)
        assert np.array_equal(a.region, b.region)
        assert all(np.array_equal(s, t) for s, t in zip(a.strokes, b.strokes, strict=True))
        for name in ("starts", "speed"):
            u, v = getattr(a, name), getattr(b, name)
            assert (u is None and v is None) or np.array_equal(u, v)
        assert a.key(back.photo_key, back.shape) == b.key(full.photo_key, full.shape)
    # A parameter changed on the proxy follows; a region changed there is scaled from it.
    proxy.update("flicker", seed=5)
    assert proxy.resized().layer("flicker").seed == 5
    assert np.array_equal(proxy.resized().layer("flicker").region, full.layer("flicker").region)
    small = np.zeros((36, 64), bool)
    small[0:12, 40:64] = True
    proxy.update("frost", region=small, starts=[[6.0, 50.0]])
    frost = proxy.resized().layer("frost")
    assert frost.region.shape == (108, 192)
    assert frost.starts.tolist() == [[18.0, 150.0]]
    assert (frost.region > 0.5).sum() == pytest.approx(small.sum() * 9, rel=0.1)
    # A smaller size of the same scene, and a size larger than the photo keeps the photo's.
    assert proxy.resized(96).shape == (54, 96)
    assert proxy.resized(4000).shape == (108, 192)


def test_a_proxy_exports_the_full_size_frames(tmp_path):
    # render(proxy.resized(), stream=True) -- the app's Export -- writes the frames of
    # the scene built at full size (a small "full" size keeps the test quick).
    from fluidnb import Clip

    photo = sample("lake", size=160)  # 90 x 160
    region = _box(photo.shape[:2], (0.45, 0.7), (0.0, 1.0))
    layer = Layer("flicker", region, FLICKER, seed=3)
    proxy = Scene(photo, [layer], size=64, fps=8.0)
    preview = render(proxy)
    assert preview.frames.shape[1:3] == (36, 64)
    path = render(proxy.resized(), stream=True).save(tmp_path / "full.npz")
    saved = Clip.load(path)
    built = render(Scene(photo, [layer], size=None, fps=8.0))
    assert saved.frames.shape == built.frames.shape == (len(preview), 90, 160, 3)
    assert np.array_equal(saved.frames, built.frames)
    assert np.array_equal(
        saved.frames[:, ~region], np.broadcast_to(photo[~region], saved.frames[:, ~region].shape)
    )
    assert np.abs(saved.frames[:, region] - photo[region]).max() > 0.02  # it flickers


def test_a_previewed_proxy_gives_its_export_its_length():
    # Frost fits its growth rate at each size, so its growth -- the longest layer, the
    # scene's length -- ends a few frames apart at two sizes: an export of a previewed
    # proxy keeps the preview's length; an unrendered proxy or a set duration is kept.
    photo = sample("lake", size=160)  # 90 x 160
    region = _box(photo.shape[:2], (0.1, 0.9), (0.1, 0.9))
    layer = Layer("frost", region, FrostParams(target=40, max_frames=80), seed=2)
    proxy = Scene(photo, [layer], size=64, fps=8.0)
    assert proxy.resized().duration is None  # nothing rendered yet
    preview = render(proxy)
    full = proxy.resized()
    assert full.duration == pytest.approx(len(preview) / 8.0)
    assert len(render(full, stream=True)) == len(preview)
    assert Scene(photo, [layer], size=64, fps=8.0, duration=3.0).resized().duration == 3.0


def test_resizing_refuses_bad_input():
    photo = sample("lake", size=96)  # 54 x 96
    scene = Scene(photo, size=48)
    with pytest.raises(ValueError, match="size"):
        scene.resized(4)
    square = np.zeros((50, 50), bool)
    square[10:20, 10:20] = True
    with pytest.raises(ValueError, match=r"region shape \(50, 50\) is neither the scene's"):
        scene.add(Layer("fire", square))
    with pytest.raises(ValueError, match=r"layer must be a fluidnb\.scene\.Layer"):
        scene.fit("fire")


def test_the_default_frost_branches_and_fills_its_region():
    # The scene's default frost was Reiter's deterministic model (rth = 0): the same
    # six-armed star for every seed, its thin ice a faint hexagon around it -- not
    # frost on a window at any size (docs/contact/scene_hd_frost_*). With rth > 0 the
    # arms branch at random: two seeds give different ice, spread over the region
    # rather than lying on six rays from the start.
    from fluidnb.scene import run_layer

    h, w = 135, 240
    yy, xx = np.mgrid[0:h, 0:w]
    corner = (yy / (0.45 * h)) ** 2 + (xx / (0.30 * w)) ** 2 < 1
    photo = np.full((h, w, 3), 0.4, np.float32)
    (r0, c0), ice = innermost_point(corner)[0], []
    for seed in (1, 2):
        layer = run_layer(Layer("frost", corner, seed=seed), photo, stream=True)
        alpha = layer.picture(len(layer) - 1)[1]
        ice.append(alpha)
        thick = (alpha > 0.5) & corner
        assert thick.sum() > 0.3 * corner.sum()
        dy, dx = yy[thick] - r0, xx[thick] - c0
        far = np.hypot(dy, dx) > 6
        off_axis = np.degrees(np.arctan2(-dy[far], dx[far])) % 60
        on_a_ray = np.minimum(off_axis, 60 - off_axis) < 6  # within 6 degrees of an arm
        assert on_a_ray.mean() < 0.35  # the star had 0.40 (uniform: 0.2)
    assert np.abs(ice[0] - ice[1])[corner].mean() > 0.05  # the star: 0 (seed ignored)
