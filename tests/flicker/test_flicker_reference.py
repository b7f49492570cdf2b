"""The fast path (FlickerModel: grouped, pruned inverse DFTs, a thread pool) equals the
literal 3-D spectrum of fluidnb.flicker._reference on small inputs."""

import numpy as np
import pytest

from fluidnb.flicker import FlickerModel, FlickerParams, flicker
from fluidnb.flicker._reference import flicker_reference
from tests.flicker.test_flicker_invariants import heights, photo

FLOWS = {"plane": None, "convex": None, "concave": None, "flow": (0.3, -0.45)}


@pytest.mark.parametrize("mapping", list(FLOWS))
@pytest.mark.parametrize(("beta", "norm"), [(0.0, "rms"), (2.0, "rms"), (2.0, "peak")])
def test_the_fast_path_equals_the_reference(mapping, beta, norm):
    img = photo((18, 26, 3), seed=4)
    p = FlickerParams(mapping=mapping, beta=beta, noise_norm=norm, T=16, f0=3, bump=4.0, k=2.0)
    flow = FLOWS[mapping]
    H_ref, frames_ref = flicker_reference(img, p, flow=flow, seed=7)
    model = FlickerModel(img, params=p, flow=flow, seed=7)
    np.testing.assert_allclose(heights(model), H_ref, rtol=0, atol=2e-5)
    np.testing.assert_allclose(model.frames(), frames_ref, rtol=0, atol=2e-4)
    # and the public function is that model
    clip = flicker(img, params=p, flow=flow, seed=7)
    assert np.array_equal(clip.frames, model.frames())


@pytest.mark.parametrize("flow", [(0.5, 0.1), (-0.3, 0.0), (0.0, 0.0)])
def test_the_fast_path_equals_the_reference_for_flows_down_up_and_still(flow):
    # Mostly vertical flows prune the other axis of the inverse DFTs.
    img = photo((22, 17, 3), seed=3)
    p = FlickerParams(mapping="flow", T=16, f0=3, bump=4.0, k=2.0)
    H_ref, frames_ref = flicker_reference(img, p, flow=flow, seed=1)
    model = FlickerModel(img, params=p, flow=flow, seed=1)
    np.testing.assert_allclose(heights(model), H_ref, rtol=0, atol=2e-5)
    np.testing.assert_allclose(model.frames(), frames_ref, rtol=0, atol=2e-4)


def test_the_reference_is_the_falling_branch_too_and_grey():
    img = photo((15, 21), seed=1)
    p = FlickerParams(mapping="convex", branch="falling", T=12, f0=2)
    H_ref, frames_ref = flicker_reference(img, p, seed=3)
    model = FlickerModel(img, params=p, seed=3)
    np.testing.assert_allclose(heights(model), H_ref, rtol=0, atol=2e-5)
    np.testing.assert_allclose(model.frames(), frames_ref, rtol=0, atol=2e-4)


@pytest.mark.parametrize("mapping", ["convex", "flow"])
def test_the_fast_path_equals_the_reference_with_noise_regions(mapping):
    img = photo((18, 26, 3), seed=2)
    p = FlickerParams(mapping=mapping, T=16, f0=3, noise_regions=3, bump=4.0, k=2.0)
    flow = FLOWS[mapping]
    H_ref, frames_ref = flicker_reference(img, p, flow=flow, seed=5)
    model = FlickerModel(img, params=p, flow=flow, seed=5)
    np.testing.assert_allclose(heights(model), H_ref, rtol=0, atol=2e-5)
    np.testing.assert_allclose(model.frames(), frames_ref, rtol=0, atol=2e-4)
