"""keyframe_preview: one keyframe of fire() on the flame's warm-up, its parts kept."""

import numpy as np
import pytest

from fluidnb.data import sample
from fluidnb.fire import FireParams, fire, keyframe_preview
from fluidnb.fire import _preview as impl
from fluidnb.fluid import flame_preset, simulate


def forget():
    impl._FLAME.forget()
    impl._PHOTO.forget()


@pytest.fixture(scope="module")
def flame():
    return sample("flame", size=96, return_alpha=True)


def by_hand(photo, matte, params, size, seed):
    """The preview's definition: fire() on the warm-up's last temperature, no motion."""
    preset = flame_preset()
    shape = (size, size)
    sim = simulate(preset.params, 1, shape=shape, seed=seed, warmup=preset.warmup_for(shape))
    one = params.replace(input_size=size, output_size=size, interval=max(params.overlap + 1, 2))
    still = np.zeros((1, size, size, 2), np.float32)
    return fire(photo, (sim.temperature[-1:], still), one, matte=matte, seed=seed).keyframes[:1]


@pytest.mark.parametrize("weight", [0.2, 0.8])
def test_the_preview_is_the_keyframe_fire_makes_kept_parts_or_not(flame, weight):
    photo, matte = flame
    params = FireParams(weight=weight)
    forget()
    cold = keyframe_preview(photo, params, matte=matte, size=24, seed=5)
    warm = keyframe_preview(photo, params, matte=matte, size=24, seed=5)
    expected = by_hand(photo, matte, params, 24, 5)
    assert np.array_equal(cold.frames, expected)
    assert np.array_equal(warm.frames, expected)


def test_a_new_seed_photo_or_matte_is_not_served_from_the_kept_parts(flame):
    photo, matte = flame
    photo, matte = photo.copy(), matte.copy()
    params = FireParams()
    forget()
    first = keyframe_preview(photo, params, matte=matte, size=24, seed=5)
    other_seed = keyframe_preview(photo, params, matte=matte, size=24, seed=6)
    assert np.array_equal(other_seed.frames, by_hand(photo, matte, params, 24, 6))
    matte[: matte.shape[0] // 2] = 0.0  # changed in place
    cut = keyframe_preview(photo, params, matte=matte, size=24, seed=5)
    assert np.array_equal(cut.frames, by_hand(photo, matte, params, 24, 5))
    assert not np.array_equal(cut.frames, first.frames)
