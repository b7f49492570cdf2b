"""The live preview's kept reduced photo: the same frames as made afresh, never stale."""

import numpy as np

from fluidnb import data
from fluidnb.flicker import FlickerParams, preview
from fluidnb.flicker import _flicker as impl


def scene():
    photo = data.sample("stream", size=96)
    mask = np.zeros(photo.shape[:2], bool)
    mask[30:, :] = True
    return photo, mask


def fresh(*args, **kwargs):
    impl._REDUCED.forget()
    return preview(*args, **kwargs)


def test_a_kept_reduction_gives_the_frames_a_fresh_one_gives():
    photo, mask = scene()
    params = FlickerParams(T=16, kappa=1.5)
    first = fresh(photo, mask, params, size=48, seed=3)
    again = preview(photo, mask, params.replace(kappa=2.0), size=48, seed=3)
    made = fresh(photo, mask, params.replace(kappa=2.0), size=48, seed=3)
    assert np.array_equal(again.frames, made.frames)
    assert not np.array_equal(first.frames, made.frames)  # kappa does change the loop


def test_a_photo_or_region_changed_in_place_is_reduced_again():
    photo, mask = scene()
    params = FlickerParams(T=16)
    before = fresh(photo, mask, params, size=48, seed=3)
    photo[:, :, 0] = 1.0 - photo[:, :, 0]  # the same array, other pixels
    after = preview(photo, mask, params, size=48, seed=3)
    assert np.array_equal(after.frames, fresh(photo, mask, params, size=48, seed=3).frames)
    assert not np.array_equal(before.frames, after.frames)
    mask[:50] = False
    shrunk = preview(photo, mask, params, size=48, seed=3)
    assert np.array_equal(shrunk.frames, fresh(photo, mask, params, size=48, seed=3).frames)
    assert not np.array_equal(shrunk.frames, after.frames)
