"""Test vectors of the pipelines for hardware benches (SPEC §5): :mod:`.generate` (build,
write, check, diff, manifest), :mod:`.formats` (``.mem``/``.coe``/``.mif``/``.csv``, packed
stream words), :mod:`.export` (HLS and VHDL types of a config), :mod:`.hdl` and
:mod:`.replay` (the HDL replay, ``rangefx hdl replay``). Names below are exported lazily."""

from __future__ import annotations

from rangefx.golden import lazy_exports

_EXPORTS = {
    "FORMATS": "generate",
    "build_vectors": "generate",
    "check_vectors": "generate",
    "diff_dump": "generate",
    "load_manifest": "generate",
    "read_tap": "generate",
    "write_vectors": "generate",
    "hls_header": "export",
    "vhdl_package": "export",
}
__all__ = sorted(_EXPORTS)
__getattr__ = lazy_exports(__name__, _EXPORTS)
