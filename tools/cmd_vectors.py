"""``rangefx vectors gen|check|diff``: hardware test vectors of P1 (SPEC §5, issue 6).

* ``gen``: render a scene (optionally cropped), run P1 with every tap and write the
  vector directory atomically (``docs/vectors.md``); prints the time it took.
* ``check``: verify sizes and SHA-256 of every file, then re-run the model from the
  manifest and require byte-identical files (exit 1 on any problem).
* ``diff``: an RTL dump (``.mem`` or ``.csv``) against the expected tap: the first
  mismatch (cycle, row, col, signal, expected, got, format) and the count (exit 1 if any).
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from rangefx.golden.geometry import PinholeCamera
from rangefx.vectors.generate import (
    FORMATS,
    build_vectors,
    check_vectors,
    diff_dump,
    stream_memory_bytes,
    write_vectors,
)

from .errors import UserError, require_memory
from .outdir import atomic_output_dir
from .pipeline import load_config, p1_case_from_scene, timing_from_args

__all__ = ["add_parser", "cmd_check", "cmd_diff", "cmd_gen", "crop_case"]


def crop_case(image1, image2, camera: PinholeCamera, crop: list[int] | None):
    """Crop both images to rows ``r0:r1``, columns ``c0:c1``; shift the principal point.

    The cropped camera keeps the focal length and moves the principal point by
    ``(-c0, -r0)`` so that the range stage's pixel coordinates ``xp, yp`` of every pixel
    are those of the full image.
    """
    if crop is None:
        return image1, image2, camera
    r0, r1, c0, c1 = crop
    m, n = image1.shape
    if not (0 <= r0 < r1 <= m and 0 <= c0 < c1 <= n) or r1 - r0 < 2 or c1 - c0 < 2:
        raise UserError(
            f"--crop {r0} {r1} {c0} {c1}: need 0 <= R0 < R1 <= {m}, 0 <= C0 < C1 <= {n} "
            "and at least 2x2 pixels"
        )
    cx, cy = camera.principal_point
    cam = PinholeCamera(c1 - c0, r1 - r0, camera.f_px, cx - c0, cy - r0)
    return image1[r0:r1, c0:c1], image2[r0:r1, c0:c1], cam


def _formats(text: str) -> list[str]:
    items = [s.strip() for s in text.split(",") if s.strip()]
    bad = [s for s in items if s not in FORMATS]
    if bad:
        raise UserError(f"--formats: unknown {', '.join(bad)}; choose from {', '.join(FORMATS)}")
    return items


def cmd_gen(args: argparse.Namespace) -> int:
    formats = _formats(args.formats)
    config = load_config(args.config, args.variant, args.divider)
    timing = timing_from_args(args)
    out = Path(args.out)
    t0 = time.perf_counter()
    case = p1_case_from_scene(args.scene, seed=args.seed)
    im1, im2, cam = crop_case(case.image1, case.image2, case.camera, args.crop)
    require_memory(
        f"--hblank {timing.hblank} --vblank {timing.vblank} on {im1.shape[0]}x{im1.shape[1]} "
        "pixels (the input streams hold every cycle)",
        stream_memory_bytes(im1.shape, timing, case.mode),
    )
    t1 = time.perf_counter()
    description = {
        "source": "scene",
        "scene": args.scene,
        "seed": args.seed,
        "scene_shape": list(case.image1.shape),
        "crop": list(args.crop) if args.crop else None,
    }
    with atomic_output_dir(out) as tmp:
        try:
            vs = build_vectors(
                im1, im2, cam, case.motion, config, case.ranging, timing,
                mode=case.mode, case=description, formats=formats,
            )  # fmt: skip
        except ValueError as exc:
            raise UserError(str(exc)) from None
        t2 = time.perf_counter()
        write_vectors(tmp, vs)
    t3 = time.perf_counter()
    m, n = vs.manifest["shape"]
    figures = {
        "out": str(out),
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
            f"P1 {figures['mode']} case to {out}/ in {figures['vectors_s']:.2f} s "
            f"(model + encode {figures['build_s']:.2f} s, write {figures['write_s']:.2f} s; "
            f"scene render {figures['render_s']:.2f} s not included)"
        )
    return 0


def cmd_check(args: argparse.Namespace) -> int:
    try:
        report = check_vectors(args.dir, rerun=not args.no_rerun)
    except ValueError as exc:
        raise UserError(str(exc)) from None
    if args.json:
        print(json.dumps({**report.__dict__, "ok": report.ok}))
    else:
        for p in report.problems:
            print(f"problem: {p}")
        rerun = "model re-run identical" if report.rerun else "model not re-run"
        verdict = "OK" if report.ok else f"FAILED ({len(report.problems)} problems)"
        print(f"{args.dir}: {report.files} files, {report.bytes} bytes, {rerun}: {verdict}")
    return 0 if report.ok else 1


def cmd_diff(args: argparse.Namespace) -> int:
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
    g.add_argument("--out", required=True, help="output vector directory")
    g.add_argument(
        "--crop", type=int, nargs=4, metavar=("R0", "R1", "C0", "C1"),
        help="rows R0:R1 and columns C0:C1 of the rendered scene",
    )  # fmt: skip
    g.add_argument("--pipeline", choices=("p1",), default="p1", help="pipeline (p1)")
    g.add_argument("--config", help="word-length config TOML (default: the shipped default)")
    g.add_argument("--variant", choices=("paper", "consistent"), help="estimator variant")
    g.add_argument("--divider", choices=("restoring", "reciprocal"), help="divider model")
    g.add_argument("--hblank", type=int, default=0, help="horizontal blanking, cycles")
    g.add_argument("--vblank", type=int, default=0, help="vertical blanking, cycles")
    g.add_argument("--gap-prob", type=float, default=0.0, help="input gap probability")
    g.add_argument("--gap-seed", type=int, default=0, help="input gap seed")
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
