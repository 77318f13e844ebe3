"""``rangefx vectors gen|check|diff``: hardware test vectors of any pipeline (SPEC §5, §10).

* ``gen``: render a scene (optionally cropped), run ``--pipeline`` (any registered one) with every
  tap and write the vector directory atomically (``docs/vectors.md``); prints the time.
* ``check``: verify sizes and SHA-256 of every file, then re-run the model from the
  manifest and require byte-identical files (exit 1 on any problem).
* ``diff``: an RTL dump (``.mem`` or ``.csv``) against the expected tap: the first
  mismatch (cycle, row, col, signal, expected, got, format) and the count (exit 1 if any).
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import replace
from pathlib import Path

from rangefx.golden.geometry import PinholeCamera
from rangefx.rtl_model.config import TimingConfig
from rangefx.rtl_model.pipeline import Case
from rangefx.vectors.generate import (
    DUMP_BYTES_PER_FILE_BYTE,
    FORMATS,
    build_vectors,
    case_from_manifest,
    check_vectors,
    diff_dump,
    dump_memory_bytes,
    load_manifest,
    stream_memory_bytes,
    write_vectors,
)

from ..errors import UserError, require_memory
from ..report import atomic_output_dir
from ..studies.cases import scene_case
from ..studies.runner import load_config
from .options import (
    add_design_args,
    add_pipeline_arg,
    add_timing_args,
    design_from_args,
    out_path,
    pipeline_from_args,
    timing_from_args,
)

__all__ = ["add_parser", "cmd_check", "cmd_diff", "cmd_gen", "crop_case", "provenance_problems"]


def crop_case(case: Case, crop: list[int] | None) -> Case:
    """Crop both images to rows ``r0:r1``, columns ``c0:c1``; shift the principal point.

    The cropped camera keeps the focal length and moves the principal point by
    ``(-c0, -r0)`` so that the range stage's pixel coordinates ``xp, yp`` of every pixel
    are those of the full image.
    """
    if crop is None:
        return case
    r0, r1, c0, c1 = crop
    m, n = case.image1.shape
    if not (0 <= r0 < r1 <= m and 0 <= c0 < c1 <= n) or r1 - r0 < 2 or c1 - c0 < 2:
        raise UserError(
            f"--crop {r0} {r1} {c0} {c1}: need 0 <= R0 < R1 <= {m}, 0 <= C0 < C1 <= {n} "
            "and at least 2x2 pixels"
        )
    cx, cy = case.camera.principal_point
    cam = PinholeCamera(c1 - c0, r1 - r0, case.camera.f_px, cx - c0, cy - r0)
    return replace(
        case, image1=case.image1[r0:r1, c0:c1], image2=case.image2[r0:r1, c0:c1], camera=cam
    )


def _formats(text: str) -> list[str]:
    items = [s.strip() for s in text.split(",") if s.strip()]
    if not items:  # not the default: the user asked for something and named nothing
        raise UserError(f"--formats {text!r} names no format; choose from {', '.join(FORMATS)}")
    bad = [s for s in items if s not in FORMATS]
    if bad:
        raise UserError(f"--formats: unknown {', '.join(bad)}; choose from {', '.join(FORMATS)}")
    return items


def cmd_gen(args: argparse.Namespace) -> int:
    formats = _formats(args.formats)
    pipeline = pipeline_from_args(args)
    config = load_config(pipeline, args.config, **design_from_args(pipeline, args))
    timing = timing_from_args(args)
    out = Path(args.out)
    t0 = time.perf_counter()
    full = scene_case(args.scene, seed=args.seed)
    if full.mode not in pipeline.modes:
        raise UserError(
            f"{pipeline.name} models {' and '.join(pipeline.modes)} mode only; scene "
            f"{args.scene!r} is {full.mode}"
        )
    case = crop_case(full, args.crop)
    m, n = case.shape
    require_memory(
        f"--hblank {timing.hblank} --vblank {timing.vblank} on {m}x{n} pixels (the input "
        "streams hold every cycle)",
        stream_memory_bytes((m, n), timing, case.mode),
    )
    t1 = time.perf_counter()
    description = {
        "source": "scene",
        "scene": args.scene,
        "seed": args.seed,
        "scene_shape": list(full.image1.shape),
        "crop": list(args.crop) if args.crop else None,
    }
    with atomic_output_dir(out) as tmp:
        try:
            vs = build_vectors(
                pipeline, case, config, timing, description=description, formats=formats
            )
        except ValueError as exc:
            raise UserError(str(exc)) from None
        t2 = time.perf_counter()
        write_vectors(tmp, vs)
    t3 = time.perf_counter()
    m, n = vs.manifest["shape"]
    figures = {
        "out": str(out),
        "pipeline": pipeline.name,
        "shape": [m, n],
        "mode": vs.manifest["mode"],
        "files": len(vs.files) + 1,
        "total_bytes": vs.manifest["total_bytes"],
        "render_s": t1 - t0,
        "build_s": t2 - t1,
        "write_s": t3 - t2,
        "vectors_s": t3 - t1,
    }
    if args.json:
        print(json.dumps(figures))
    else:
        print(
            f"wrote {figures['files']} files ({figures['total_bytes']} bytes) for a {m}x{n} "
            f"{pipeline.name.upper()} {figures['mode']} case to {out}/ in "
            f"{figures['vectors_s']:.2f} s "
            f"(model + encode {figures['build_s']:.2f} s, write {figures['write_s']:.2f} s; "
            f"scene render {figures['render_s']:.2f} s not included)"
        )
    return 0


def _require_rerun_memory(directory: str) -> None:
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
    reproduce the stored vectors? :func:`check_vectors` re-runs the model on the stored
    inputs; this renders the scene the manifest names, crops it as it says and requires
    the same files, so an edited ``scene``, ``seed`` or ``crop`` is caught too."""
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


def cmd_check(args: argparse.Namespace) -> int:
    if not args.no_rerun:
        _require_rerun_memory(args.dir)
    try:
        report = check_vectors(args.dir, rerun=not args.no_rerun)
        if report.ok and report.rerun:
            report.problems += provenance_problems(args.dir)
            report.provenance = not report.problems
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if args.json:
        print(json.dumps({**report.__dict__, "ok": report.ok}))
    else:
        for p in report.problems:
            print(f"problem: {p}")
        for p in report.notes:
            print(f"note: {p}")
        rerun = "model re-run identical" if report.rerun else "model not re-run"
        if report.provenance:
            rerun = "inputs reproduced from the manifest's case, " + rerun
        verdict = "OK" if report.ok else f"FAILED ({len(report.problems)} problems)"
        print(f"{args.dir}: {report.files} files, {report.bytes} bytes, {rerun}: {verdict}")
    return 0 if report.ok else 1


def cmd_diff(args: argparse.Namespace) -> int:
    # a sparse or huge dump is refused before it is read (a MemoryError otherwise)
    need = dump_memory_bytes(args.dump)
    size = f"{need / DUMP_BYTES_PER_FILE_BYTE / 2**30:.2f} GiB"
    require_memory(f"reading dump {args.dump} ({size})", need)
    try:
        report = diff_dump(args.dir, args.dump, args.signal)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    print(json.dumps(report.as_dict()) if args.json else report.text())
    return 0 if report.ok else 1


def add_parser(sub) -> None:
    """Register ``rangefx vectors`` and its sub-commands on ``sub``."""
    p = sub.add_parser("vectors", help="hardware test vectors: gen, check, diff (SPEC §5)")
    vs = p.add_subparsers(dest="vectors_command", required=True)
    g = vs.add_parser("gen", help="write the vector directory of a scene case")
    g.add_argument("--scene", default="lab", help="scene preset (lab: stereo, runway: motion)")
    g.add_argument("--seed", type=int, default=0, help="scene noise seed")
    g.add_argument("--out", type=out_path, required=True, help="output vector directory")
    g.add_argument(
        "--crop", type=int, nargs=4, metavar=("R0", "R1", "C0", "C1"),
        help="rows R0:R1 and columns C0:C1 of the rendered scene",
    )  # fmt: skip
    add_pipeline_arg(g)
    add_design_args(g)
    add_timing_args(g)
    g.add_argument(
        "--formats", default="mem", help=f"per-tap formats, comma separated: {','.join(FORMATS)}"
    )
    g.add_argument("--json", action="store_true", help="print one JSON object (with timings)")
    g.set_defaults(func=cmd_gen)
    c = vs.add_parser("check", help="verify checksums and re-run the model")
    c.add_argument("dir", help="vector directory")
    c.add_argument("--no-rerun", action="store_true", help="checksums and sizes only")
    c.add_argument("--json", action="store_true", help="print one JSON object")
    c.set_defaults(func=cmd_check)
    d = vs.add_parser("diff", help="first mismatch of an RTL dump against an expected tap")
    d.add_argument("dir", help="vector directory")
    d.add_argument("dump", help="RTL dump, .mem ($readmemh words) or .csv (value column)")
    d.add_argument("--signal", help="tap name (default: the dump's file name, e.g. e1.row_r1)")
    d.add_argument("--json", action="store_true", help="print one JSON object")
    d.set_defaults(func=cmd_diff)
