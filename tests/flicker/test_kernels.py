"""The compiled per-frame passes (fluidnb.flicker._kernels) equal their numpy versions."""

import numpy as np
import pytest

from fluidnb.flicker import FlickerModel, FlickerParams, soft_clip
from fluidnb.flicker._flicker import _KNEE, _Scene
from fluidnb.flicker._kernels import soft_heights
from tests.flicker.test_flicker_invariants import photo


@pytest.mark.parametrize("shape", [(20, 31, 3), (17, 12), (1, 9, 3), (9, 1), (2, 2, 3)])
@pytest.mark.parametrize("k", [0.8, 3.0])  # k w > 1 somewhere: the factor is clamped at black
def test_the_compiled_shading_equals_numpy(shape, k):
    rng = np.random.default_rng(5)
    img = photo(shape, seed=2)
    mask = np.ones(shape[:2], bool)
    mask[: shape[0] // 3] = False  # a window inside the image, and a feathered edge
    if not mask.any():
        mask[:] = True
    params = FlickerParams(k=k, feather=3.0, bump=6.0)
    scene = _Scene(img, mask, params, 1.0)
    h, w = scene.alpha.shape
    slopes = (rng.standard_normal((3, h, w)) * 0.4).astype(np.float32)
    fast = scene.empty_clip(3)
    slow = scene.empty_clip(3)
    scene.render(slopes, fast[(slice(None), *scene.window)])  # a strided view
    scene.render_reference(slopes, slow[(slice(None), *scene.window)])
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-6)
    outside = ~mask
    assert np.array_equal(fast[:, outside], np.broadcast_to(img[outside], fast[:, outside].shape))


def test_the_compiled_soft_clip_equals_numpy():
    rng = np.random.default_rng(1)
    rows = (rng.standard_normal((4, 1000)) * 2).astype(np.float32)
    scale, amplitude = np.float32(0.7), np.float32(0.35)
    want = rows.copy()
    for row in want:
        row *= scale
        soft_clip(row, _KNEE, out=row)
        row *= amplitude
    got = rows.copy()
    soft_heights(got, scale, np.float32(_KNEE), amplitude)
    np.testing.assert_allclose(got, want, rtol=0, atol=1e-7)
    assert np.abs(got).max() < amplitude  # bent into (-A, A)


def test_frames_made_with_the_numpy_shading_are_the_same():
    img = photo((24, 30, 3), seed=8)
    model = FlickerModel(img, params=FlickerParams(T=16, k=2.0), seed=3)
    fast = model.frames()
    scene = model._scene
    slow = scene.empty_clip(16)
    h, w = model.alpha.shape
    scene.render_reference(model._slopes(0, 16).reshape(16, h, w), slow)
    np.testing.assert_allclose(fast, slow, rtol=0, atol=1e-6)
