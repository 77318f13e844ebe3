"""Where a vector directory came from (SPEC §5, §15): does the manifest's scene case
reproduce the stored vectors, and can its model re-run fit in memory?

:func:`rangefx.vectors.generate.check_vectors` re-runs the model on the stored inputs;
:func:`provenance_problems` renders the scene the manifest names (scene, seed, crop),
rebuilds the vectors and requires the same files, so an edited ``scene``, ``seed`` or
``crop`` is caught too. It lives here, not in ``vectors/``, because it renders scenes
(:mod:`rangefx.tools.studies.cases`).
"""

from __future__ import annotations

from pathlib import Path

from rangefx.rtl_model.config import TimingConfig
from rangefx.vectors.generate import (
    build_vectors,
    case_from_manifest,
    load_manifest,
    stream_memory_bytes,
)

from ..errors import UserError, require_memory
from .cases import crop_case, scene_case

__all__ = ["provenance_problems", "require_rerun_memory"]


def require_rerun_memory(directory: str | Path) -> None:
    """Refuse a re-run whose manifest's blanking would not fit in memory (``hblank``
    8e12 in an edited manifest), before the model allocates its streams."""
    try:
        manifest = load_manifest(directory)
        timing = TimingConfig(**manifest["timing"])
        m, n = manifest["shape"]
        need = stream_memory_bytes((int(m), int(n)), timing, manifest["mode"])
    except (ValueError, TypeError, KeyError, OverflowError):
        return  # check_vectors reports a malformed manifest as one line
    require_memory(
        f"{directory}: re-running the manifest's case (hblank {timing.hblank}, vblank "
        f"{timing.vblank} on {m}x{n} pixels; --no-rerun checks the files only)",
        need,
    )


def provenance_problems(directory: str | Path) -> list[str]:
    """Does the manifest's case (scene, seed, crop; with its config, timing and formats)
    reproduce the stored vectors? A problem line per failure; empty when it does."""
    manifest = load_manifest(directory)
    desc = manifest.get("case", {})
    if desc.get("source") != "scene":
        return [f"manifest case: source {desc.get('source')!r} is not a scene preset; "
                "the inputs' provenance cannot be checked"]  # fmt: skip
    scene, seed, crop = desc.get("scene"), desc.get("seed"), desc.get("crop")
    what = f"scene {scene!r}, seed {seed!r}, crop {crop!r}"
    try:
        if not isinstance(seed, int) or isinstance(seed, bool):
            raise UserError(f"seed {seed!r} is not an integer")
        if crop is not None and (
            not isinstance(crop, list) or len(crop) != 4
            or not all(isinstance(v, int) and not isinstance(v, bool) for v in crop)
        ):  # fmt: skip
            raise UserError(f"crop {crop!r} is not four integers")
        case = crop_case(scene_case(str(scene), seed=seed), crop)
        rebuilt = case_from_manifest(directory, manifest)
        if case.mode != rebuilt["case"].mode:
            raise UserError(f"scene {scene!r} is {case.mode}, the vectors {rebuilt['case'].mode}")
        again = build_vectors(**{**rebuilt, "case": case})
    except (UserError, ValueError) as exc:
        return [f"manifest case ({what}) cannot be reproduced: {exc}"]
    d = Path(directory)
    bad = [name for name, data in again.files.items()
           if not (d / name).is_file() or (d / name).read_bytes() != data]  # fmt: skip
    if bad:
        return [f"manifest case ({what}) does not reproduce the stored vectors: "
                f"{len(bad)} files differ, first {min(bad, key=_inputs_first)}"]  # fmt: skip
    return []


def _inputs_first(name: str) -> tuple[bool, str]:
    return (".pix_in." not in name, name)
