"""Reports: tables (Table 1 style), figures (Figs 3, 4, 8), word-length study plots and
the output directories rangefx writes (atomic, marked, never a user's file replaced)."""

from .outdir import MARKER_NAME, atomic_output_dir, atomic_write_bytes, atomic_write_text
from .plots import (
    new_figure,
    range_points_3d,
    range_to_gray,
    save_error_histogram_png,
    save_pair_png,
    save_png,
    save_points_3d_png,
    save_range_map_png,
)
from .tables import (
    ROW_KEYS,
    ReportObject,
    format_side_by_side,
    json_safe,
    median_text,
    object_table,
    overall_metrics,
    table_csv,
    table_markdown,
)

__all__ = [
    "MARKER_NAME",
    "ROW_KEYS",
    "ReportObject",
    "atomic_output_dir",
    "atomic_write_bytes",
    "atomic_write_text",
    "format_side_by_side",
    "json_safe",
    "median_text",
    "new_figure",
    "object_table",
    "overall_metrics",
    "range_points_3d",
    "range_to_gray",
    "save_error_histogram_png",
    "save_pair_png",
    "save_png",
    "save_points_3d_png",
    "save_range_map_png",
    "table_csv",
    "table_markdown",
]
