"""From what a user draws to plain arrays: strokes, brushes and direction fields."""

from ._direction import check_strokes, direction_field, resample_stroke, stroke_tangents
from ._draw import arrow_heads, quiver_segments, scalar_to_rgba, segment_heads
from ._files import load_strokes, save_strokes
from ._paint import flood_fill, paint_disk, paint_segment

__all__ = [
    "arrow_heads",
    "check_strokes",
    "direction_field",
    "flood_fill",
    "load_strokes",
    "paint_disk",
    "paint_segment",
    "quiver_segments",
    "resample_stroke",
    "save_strokes",
    "scalar_to_rgba",
    "segment_heads",
    "stroke_tangents",
]
