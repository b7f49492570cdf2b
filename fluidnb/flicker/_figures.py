"""Teaching figures: the spectrum, the mapping, a pixel's temporal spectrum, Fig. 8-11.

Matplotlib's object API only (no pyplot), so figures can be made in a worker thread
and outside Jupyter.
"""

from __future__ import annotations

import numpy as np

from .._validation import check_range

__all__ = ["analysis_figure", "difference_image"]


def difference_image(a, b, *, percentile=99.5):
    """The paper's difference image of two frames, contrast-stretched (Fig. 8-11 (d), (e)).

    Parameters
    ----------
    a, b : array_like, shape (H, W) or (H, W, 3)
        Two frames.
    percentile : float
        The absolute difference is divided by this percentile of itself (the paper
        stretches the histogram "to make it visible") and clipped to [0, 1].

    Returns
    -------
    ndarray, shape (H, W), float32 in [0, 1]
        Mean over channels of ``|a - b|``, stretched.

    Examples
    --------
    >>> a = np.zeros((2, 2))
    >>> b = np.array([[0.0, 0.1], [0.2, 0.4]])
    >>> difference_image(a, b, percentile=100).tolist()
    [[0.0, 0.25], [0.5, 1.0]]
    """
    a = np.asarray(a, np.float32)
    b = np.asarray(b, np.float32)
    if a.shape != b.shape:
        raise ValueError(f"a and b must have the same shape, got {a.shape} and {b.shape}")
    percentile = check_range("percentile", percentile, 0, 100, lo_open=True)
    d = np.abs(a - b)
    if d.ndim == 3:
        d = d.mean(axis=-1)
    top = float(np.percentile(d, percentile))
    return np.clip(d / top, 0, 1).astype(np.float32) if top > 0 else d


def analysis_figure(model, *, pixel=None, t0=0, dt=0.5, figsize=(11, 5.4)):
    r"""One figure of what the model did: spectrum, mapping, a pixel's spectrum, Fig. 8-11.

    Parameters
    ----------
    model : FlickerModel
        The model to show.
    pixel : (int, int), optional
        (row, col) of the pixel whose temporal spectrum is shown; default the centre
        of the region.
    t0 : int
        First frame of the Fig. 8-11 row.
    dt : float
        Seconds between the frames of that row (the paper: 0.5 s).
    figsize : (float, float)
        Figure size in inches.

    Returns
    -------
    matplotlib.figure.Figure
        Top row: :math:`\log|F|` of Eq. (4), the mapped :math:`f_c` of Eq. (7)-(9), the
        temporal power spectrum of the height at ``pixel``. Bottom row: frames
        ``t0``, ``t0 + dt``, ``t0 + 2 dt`` and the two stretched differences.
    """
    from matplotlib.figure import Figure

    from ._flicker import FlickerModel

    if not isinstance(model, FlickerModel):
        raise ValueError(f"model must be a FlickerModel, got {type(model).__name__}")
    p = model.params
    h, w = model.shape
    mask = model.mask
    if pixel is None:
        rows, cols = np.nonzero(mask)
        k = int(np.argmin((rows - rows.mean()) ** 2 + (cols - cols.mean()) ** 2))
        pixel = (int(rows[k]), int(cols[k]))
    r, c = (int(round(v)) for v in pixel)
    if not (0 <= r < h and 0 <= c < w):
        raise ValueError(f"pixel must lie inside the image {(h, w)}, got {pixel}")
    step = max(1, int(round(dt * p.fps)))

    fig = Figure(figsize=figsize, layout="constrained")
    top = fig.subfigures(2, 1, height_ratios=[1.15, 1])
    ax = top[0].subplots(1, 3)
    # Both spectra in cycles per pixel of the model's grid: square panels whatever the
    # shape of the analysed window.
    F = np.fft.fftshift(model.spectrum)
    h_w, w_w = F.shape
    extent = [-0.5, 0.5 - 1 / w_w, 0.5 - 1 / h_w, -0.5]
    look = {"extent": extent, "aspect": "auto", "interpolation": "nearest"}
    ax[0].imshow(np.log10(np.abs(F) + 1e-9), cmap="magma", **look)
    ax[0].set_title("log |F(fx, fy)|, Eq. (4)")
    fc = np.fft.fftshift(model.frequencies)
    im = ax[1].imshow(fc, cmap="viridis", **look)
    top[0].colorbar(im, ax=ax[1], shrink=0.8, label="f_c (per loop)")
    ax[1].set_title(f"mapped f_c, {p.mapping}")
    for a in ax[:2]:
        a.set_box_aspect(1)
        a.set_xlabel("nu_x (cycles/pixel)", fontsize=8)
    ax[0].set_ylabel("nu_y", fontsize=8)
    series = np.array([model.height(t)[r, c] for t in range(p.T)]) - p.C
    power = np.abs(np.fft.rfft(series)) ** 2
    ax[2].semilogy(np.arange(len(power)), power + 1e-12, "o-", ms=3)
    ax[2].axvline(p.f0, color="C1", ls="--", lw=1, label=f"f0 = {p.f0}")
    ax[2].set_xlabel("f_t (oscillations per loop)")
    ax[2].set_title(f"power of H at pixel ({r}, {c})")
    ax[2].legend(loc="upper right", fontsize=8)

    frames = [model.frame(t0 + i * step) for i in range(3)]
    bottom = top[1].subplots(1, 5)
    names = [
        f"(a) frame {t0}",
        f"(b) +{step / p.fps:g} s",
        f"(c) +{2 * step / p.fps:g} s",
        "(d) |a - b|",
        "(e) |b - c|",
    ]
    shown = [
        *frames,
        difference_image(frames[0], frames[1]),
        difference_image(frames[1], frames[2]),
    ]
    for a, img, name in zip(bottom, shown, names):
        a.imshow(img, cmap="gray", vmin=0, vmax=1)
        a.set_title(name, fontsize=9)
        a.set_xticks([])
        a.set_yticks([])
    bottom[0].plot([c], [r], "c+", ms=8)
    return fig
