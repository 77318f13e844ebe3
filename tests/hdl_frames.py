"""A stream of two frames through the RTL: the vector directory of one frame made into a
stream of the same frame twice, back to back, and the bench's dump checked against the
one frame's vectors (``tests/test_hdl_p2.py``, ``tests/test_hdl.py``)."""

from __future__ import annotations

import hashlib
import json
import shutil
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from rangefx.vectors.generate import read_tap, tap_cycles


def two_frames(vec: Path, out: Path) -> int:
    """Copy the vector directory ``vec`` to ``out`` with input streams that carry its
    frame twice, back to back (each copy: the frame's beats and its trailing blanking,
    the manifest's ``vblank``): frame 2's first beat comes ``count`` cycles after frame
    1's. Returns ``count``."""
    shutil.copytree(vec, out)
    manifest = json.loads((vec / "manifest.json").read_text())
    count = 0
    for e in manifest["files"]:
        if e["kind"] == "stream" and e["path"].endswith(".mem"):
            head, _, body = (vec / e["path"]).read_text().partition("\n")
            data = f"{head}\n{body}{body}".encode()
            (out / e["path"]).write_bytes(data)
            count = int(e["count"])
            e.update(size=len(data), sha256=hashlib.sha256(data).hexdigest(), count=2 * count,
                     valid_count=2 * int(e["valid_count"]), frames=2)  # fmt: skip
    for key in ("total_cycles",):
        if key in manifest:
            manifest[key] = int(manifest[key]) + count
    (out / "manifest.json").write_text(json.dumps(manifest, indent=1) + "\n")
    return count


def two_frame_report(vec: Path, dump: Path, count: int, taps: Sequence[str],
                     lines: Sequence[int]) -> dict:  # fmt: skip
    """A two-frame dump against the vectors of one frame ``vec``: per tap, frame 1's
    samples (in cycle order) against the vectors' values and cycles, frame 2's against
    the same values at the vectors' cycles + ``count`` (a lone frame's schedule); the
    AXI4-Stream output's TLAST-delimited lines (``lines``: one frame's line lengths) and
    TUSER on each frame's first; the flags; the overflow counters (from reset: twice the
    manifest's). Returns ``values`` and ``cycles`` (mismatch counts, missing or extra
    samples counted in both), ``first`` (the first mismatch: tap, index, frame, cycle,
    got_cycle), ``framing_ok``, ``status`` (the dump's) and ``counters_ok``."""
    manifest = json.loads((vec / "manifest.json").read_text())
    m, n = manifest["shape"]
    got = np.load(dump / "taps.npz")
    report: dict = {"values": 0, "cycles": 0, "first": None}
    for tap in taps:
        entry = next(e for e in manifest["files"] if e["tap"] == tap and e["kind"] != "stream"
                     and e["path"].endswith(".mem"))  # fmt: skip
        cyc = tap_cycles(vec, manifest, tap, int(entry["first_valid_cycle"]))
        order = np.argsort(cyc, kind="stable")
        val = read_tap(vec, tap, manifest)[order] & ((1 << int(entry["word"])) - 1)
        want_c = np.concatenate([cyc[order], cyc[order] + count])
        want_v = np.concatenate([val, val])
        g_c, g_v = got[f"{tap}.cycle"], got[f"{tap}.value"]
        k = min(g_c.size, want_c.size)
        extra = abs(g_c.size - want_c.size)
        bad_v = np.flatnonzero(g_v[:k] != want_v[:k])
        bad_c = np.flatnonzero(g_c[:k] != want_c[:k])
        report["values"] += bad_v.size + extra
        report["cycles"] += bad_c.size + extra
        bad = np.union1d(bad_v, bad_c)
        if (bad.size or extra) and report["first"] is None:
            i = int(bad[0]) if bad.size else k
            report["first"] = {"tap": tap, "index": i, "frame": 1 + i // (m * n),
                               "cycle": int(want_c[i]) if i < want_c.size else None,
                               "got_cycle": int(g_c[i]) if i < g_c.size else None}  # fmt: skip
    out = np.load(dump / "m_axis.npz")
    tuser = [1] + [0] * (len(lines) - 1)
    report["framing_ok"] = (out["line_lengths"].tolist() == list(lines) * 2
                            and out["first_tuser"].tolist() == tuser * 2)  # fmt: skip
    status = json.loads((dump / "status.json").read_text())
    report["status"] = status
    report["counters_ok"] = all(status["overflows"].get(s, 0) == 2 * c
                                for s, c in manifest.get("overflows", {}).items())  # fmt: skip
    return report
