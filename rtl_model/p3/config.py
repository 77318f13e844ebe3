"""Word-length and design configuration of the P3 pipeline (multi-scale G6, SPEC §12).

:class:`P3Config` is the P3 case of the one word-length config type
:class:`~rangefx.rtl_model.config.WordLengthConfig`: one format per name of
:data:`P3_SIGNALS` (``docs/multiscale.md``, "P3: the fixed-point datapath") plus the
design fields, which are G6's settings (:class:`~rangefx.golden.multiscale.MultiscaleConfig`)
and the hardware choices (Keys weight ROM, divider); TOML, validation and the int64 check
naming the signal are shared.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import ClassVar

from rangefx.golden.multiscale import MultiscaleConfig

from ..config import Terms, WordLengthConfig, signed_bits
from ..fixedpoint import FixedFormat
from ..runtime import DIVIDERS

__all__ = ["P3_SIGNALS", "P3Config"]

#: (name, meaning) of every P3 signal and register, in datapath order.
_SIGNAL_TABLE: tuple[tuple[str, str], ...] = (
    ("p3_pix", "input pixels E1, E2 (grey levels; level 0 of the pyramid)"),
    ("p3_pyr", "pyramid levels 1.. of E1, E2 (5-tap binomial reduce)"),
    ("p3_nbox", "register: 1 / (2R + 1)^2, the weight of the normalisation's box mean"),
    ("p3_norm", "N = E - mean(E) over the box, each camera and level"),
    (
        "p3_grad",
        "central differences along the row, E1x and Wx (eqs 18-19), and with vertical "
        "down the columns, E1y and Wy",
    ),
    ("p3_keys", "ROM: Keys cubic weights of the warp, 4 per fraction index"),
    ("p3_warp", "W = E2(x - u), the warped second image (Keys cubic)"),
    ("p3_g", "g = (E1x + Wx) / 2, the eq 6 mean gradient"),
    ("p3_gy", "vertical: gy = (E1y + Wy) / 2, the mean gradient down the columns"),
    ("p3_e", "e = E1 - W, c1 of eq 10 about the current estimate"),
    ("p3_bgg", "box form: sum of g^2 over the (2 rv + 1)^2 box"),
    ("p3_bge", "box form: sum of g e over the box"),
    ("p3_byy", "box form: sum of gy^2 over the box"),
    ("p3_bgy", "box form: sum of g gy over the box"),
    ("p3_bye", "box form: sum of gy e over the box"),
    ("p3_bdet", "box form: bdet = bgg byy - bgy^2, the box's 2x2 determinant"),
    ("p3_bnv", "box form: bnv = bgg bye - bgy bge, v's numerator"),
    ("p3_v", "box form: v = -bnv / bdet (divider quotient; 0 where bdet <= 0)"),
    ("p3_ev", "box form: e + gy v, with v of the line rv lines up (the 1-D fit's e)"),
    ("p3_win", "register: Gaussian window taps w_0..w_r (symmetric)"),
    ("p3_rgg", "row pass of the window on g^2"),
    ("p3_rge", "row pass of the window on g e"),
    ("p3_ree", "row pass of the window on e^2"),
    ("p3_ryy", "vertical: row pass of the window on gy^2"),
    ("p3_rgy", "vertical: row pass of the window on g gy"),
    ("p3_rye", "vertical: row pass of the window on gy e"),
    ("p3_sgg", "window sum of g^2 (column pass) and the T_g^2 register"),
    ("p3_sge", "window sum of g e (column pass)"),
    ("p3_see", "window sum of e^2 (column pass)"),
    ("p3_syy", "vertical: window sum of gy^2 (column pass)"),
    ("p3_sgy", "vertical: window sum of g gy (column pass)"),
    ("p3_sye", "vertical: window sum of gy e (column pass)"),
    ("p3_det", "vertical: det = sum(g^2) sum(gy^2) - sum(g gy)^2, the 2x2 system's determinant"),
    ("p3_nu", "vertical: nu = sum(gy^2) sum(g e) - sum(g gy) sum(gy e), the numerator of du"),
    ("p3_nv", "vertical: nv = sum(g^2) sum(gy e) - sum(g gy) sum(g e), v's numerator (residual)"),
    (
        "p3_du",
        "du = -sum(g e) / sum(g^2), with vertical -nu / det (divider quotient, eq 10 "
        "normal equations)",
    ),
    ("p3_u", "disparity u (px of its level), its expansion, registers u_max, u_min"),
    (
        "p3_res",
        "residual test: sum(e^2) sum(g^2) - sum(g e)^2 and T_r^2 sum(g^2); with "
        "vertical sum(e^2) det - sum(g e) nu - sum(gy e) nv and T_r^2 det",
    ),
    ("p3_tr2", "register: T_r^2"),
    ("p3_fb", "register: f B (px x length unit)"),
    ("p3_range", "range z = f B / u (divider quotient) and range_max"),
)

#: G6's settings among the design fields (the golden reads these and nothing else).
MULTISCALE_FIELDS: tuple[str, ...] = (
    "levels",
    "warps",
    "sigma",
    "radius",
    "threshold_g",
    "threshold_r",
    "coarse_px",
    "max_disparity",
    "coarse_lag",
    "normalise",
    "normalise_radius",
    "vertical",
    "vertical_radius",
)
#: The normalisations P3 builds (G6's ``"zncc"`` needs a square root and a divider per
#: pixel and camera: golden only).
P3_NORMALISATIONS: tuple[str, ...] = ("none", "local_mean")
#: G6's measured defaults: P3's design fields default to them.
_G6 = MultiscaleConfig()


@dataclass(frozen=True, kw_only=True)
class P3Config(WordLengthConfig):
    """Formats of every P3 signal plus the design choices.

    Attributes
    ----------
    formats
        One :class:`FixedFormat` per name in :data:`P3_SIGNALS`.
    warps, sigma, radius, threshold_g, threshold_r, coarse_px, coarse_lag
        G6's settings (:class:`~rangefx.golden.multiscale.MultiscaleConfig`).
    levels
        Pyramid levels; 0 = chosen from the disparity limit (G6's ``None``,
        :func:`~rangefx.golden.multiscale.auto_levels`).
    max_disparity
        Largest disparity, px of the input (the clip and the E2 row buffers): the
        user's setting; 0 = chosen from the image width (G6's ``None``,
        :data:`~rangefx.golden.multiscale.AUTO_DISPARITY_FRACTION` of it).
    normalise, normalise_radius
        G6's photometric normalisation, one of :data:`P3_NORMALISATIONS` (``"none"``:
        the warps read the pyramid's ``p3_pix`` / ``p3_pyr``; ``"local_mean"``: each
        level's ``p3_norm``), and its box radius.
    vertical, vertical_radius
        G6's vertical term: with ``vertical_radius`` 0 the window's 2x2 normal equations
        in (u, v), ``v`` estimated and discarded (``p3_gy`` .. ``p3_nv``; the determinant
        test for validity); above 0 the box form, ``v`` from the 2x2 system over the
        ``(2 rv + 1)²`` box (``p3_bgg`` .. ``p3_v``), ``rv`` lines late, and the 1-D fit on
        ``p3_ev`` (:attr:`vertical_form`).
    keys_bits
        Fraction bits of the warp's position ``x - u`` (rounded to them) that index the
        Keys weight ROM (``2**keys_bits`` rows of 4 weights).
    divider, recip_lut_bits, recip_bits
        The shared divider model of both quotients (``p3_du``, ``p3_range``).
    """

    PIPELINE: ClassVar[str] = "p3"
    SIGNAL_TABLE: ClassVar[tuple[tuple[str, str], ...]] = _SIGNAL_TABLE
    HOST_REGISTERS: ClassVar[tuple[str, ...]] = ("p3_nbox", "p3_win", "p3_tr2", "p3_fb")
    QUOTIENTS: ClassVar[tuple[str, ...]] = ("p3_du", "p3_v", "p3_range")
    DOC: ClassVar[str] = "docs/multiscale.md"

    levels: int = 0
    warps: int = _G6.warps
    sigma: float = _G6.sigma
    radius: int = _G6.radius
    threshold_g: float = _G6.threshold_g
    threshold_r: float = _G6.threshold_r
    coarse_px: float = _G6.coarse_px
    max_disparity: float = 0.0
    coarse_lag: int = _G6.coarse_lag
    normalise: str = _G6.normalise
    normalise_radius: int = _G6.normalise_radius
    vertical: bool = _G6.vertical
    vertical_radius: int = _G6.vertical_radius
    keys_bits: int = 8
    divider: str = "reciprocal"
    recip_lut_bits: int = 8
    recip_bits: int = 20

    def validate_design(self) -> None:
        md = self.max_disparity
        if isinstance(md, bool) or not isinstance(md, int | float) or not 0 <= md < math.inf:
            raise ValueError(f"max_disparity must be a number >= 0 (0: the claim), not {md!r}")
        try:
            self.multiscale()
        except TypeError as exc:
            raise ValueError(str(exc)) from None
        if self.normalise not in P3_NORMALISATIONS:
            raise ValueError(
                f"P3 builds normalise {' or '.join(map(repr, P3_NORMALISATIONS))}, not "
                f"{self.normalise!r} (G6 only)"
            )
        self.check_int_field("keys_bits", 1, 12)
        self.check_choice("divider", DIVIDERS)
        self.check_reciprocal_fields()
        for name in ("p3_pix", "p3_pyr", "p3_nbox", "p3_win", "p3_tr2", "p3_fb", "p3_range"):
            if self.formats[name].signed:
                raise ValueError(f"signal {name!r} must be unsigned (it is never negative)")
        for name in ("p3_u", "p3_keys", "p3_win", "p3_sgg"):
            if not 0 <= self.formats[name].frac <= 40:
                raise ValueError(f"signal {name!r} must have 0..40 fraction bits")
        if not math.isfinite(float(self.threshold_r) * float(self.threshold_r)):
            raise ValueError(
                f"threshold_r = {self.threshold_r!r}: its square T_r^2 is not a finite number"
            )
        for name, why in (("p3_keys", "Keys weights are negative"),
                          ("p3_norm", "the local mean is removed")):  # fmt: skip
            if not self.formats[name].signed:
                raise ValueError(f"signal {name!r} must be signed ({why})")

    def design_register_values(self) -> Iterable[tuple[str, str, float, str]]:
        """Besides the base class's: ``T_g^2`` (``p3_sgg``) and, when set, the disparity
        limit ``u_max`` of level 0 (``max_disparity``, ``p3_u``), as
        :class:`~rangefx.rtl_model.p3.model.P3Registers` writes them. ``T_r^2`` is held at
        its format's limit by design (no residual test above it)."""
        yield from super().design_register_values()
        tg2 = float(self.threshold_g) * float(self.threshold_g)  # inf, not OverflowError
        yield "threshold_g", f"threshold_g = {self.threshold_g!r} (T_g^2 = {tg2:g})", tg2, "p3_sgg"
        if self.max_disparity:
            md = float(self.max_disparity)
            yield "max_disparity", f"max_disparity = {md!r} (u_max)", md, "p3_u"

    @property
    def vertical_form(self) -> str:
        """G6's :attr:`~rangefx.golden.multiscale.MultiscaleConfig.vertical_form`."""
        return self.multiscale().vertical_form

    def multiscale(self) -> MultiscaleConfig:
        """The golden G6 settings of this config."""
        kw = {k: getattr(self, k) for k in MULTISCALE_FIELDS}
        kw["max_disparity"] = float(self.max_disparity) or None
        kw["levels"] = self.levels or None
        return MultiscaleConfig(**kw)

    def exact_intermediates(self) -> Iterable[tuple[str, Terms, int]]:
        f = self.formats
        pyr = f["p3_pix"] if signed_bits(f["p3_pix"]) >= signed_bits(f["p3_pyr"]) else f["p3_pyr"]
        # the reduce: 25 products of the binomial weights (<= 36, 7 bits) with a parent pixel
        binom = FixedFormat(False, 6, 0)
        yield "p3_pyr", ((binom, pyr),) * 25, 0
        level = pyr  # what the warps read: the pyramid, or each level normalised
        if self.normalise != "none":  # E 2^f_nbox - c Σ_box E, exact
            box = (2 * self.normalise_radius + 1) ** 2
            yield "p3_norm", ((pyr, f["p3_nbox"]), *((f["p3_nbox"], pyr),) * box), 0
            level = f["p3_norm"]
        yield "p3_grad", ((level,), (level,), (f["p3_warp"],), (f["p3_warp"],)), 1
        yield "p3_warp", ((f["p3_keys"], level),) * 4, 0
        yield "p3_g", ((f["p3_grad"],), (f["p3_grad"],)), 1
        yield "p3_e", ((level,), (f["p3_warp"],)), 0
        taps = 2 * self.radius + 1
        win, g, e = f["p3_win"], f["p3_g"], f["p3_e"]
        yield "p3_rgg", ((win, g, g),) * taps, 0
        yield "p3_rge", ((win, g, e),) * taps, 0
        yield "p3_ree", ((win, e, e),) * taps, 0
        for row, col in (("p3_rgg", "p3_sgg"), ("p3_rge", "p3_sge"), ("p3_ree", "p3_see")):
            yield col, ((win, f[row]),) * taps, 0
        yield "p3_u", ((f["p3_u"],), (f["p3_du"],)), 0
        yield "p3_u", ((f["p3_u"],),) * 4, 1  # the expand
        yield "p3_res", ((f["p3_see"], f["p3_sgg"]), (f["p3_sge"], f["p3_sge"])), 0
        yield "p3_res", ((f["p3_tr2"], f["p3_sgg"]),), 0
        form = self.vertical_form
        if form == "off":
            return
        if form == "box":
            yield from self._box_intermediates(level)
            return
        yield "p3_grad", ((level,), (level,), (f["p3_warp"],), (f["p3_warp"],)), 1
        yield "p3_gy", ((f["p3_grad"],), (f["p3_grad"],)), 1
        gy = f["p3_gy"]
        yield "p3_ryy", ((win, gy, gy),) * taps, 0
        yield "p3_rgy", ((win, g, gy),) * taps, 0
        yield "p3_rye", ((win, gy, e),) * taps, 0
        for row, col in (("p3_ryy", "p3_syy"), ("p3_rgy", "p3_sgy"), ("p3_rye", "p3_sye")):
            yield col, ((win, f[row]),) * taps, 0
        sgg, sge, see, syy, sgy, sye = (
            f[s] for s in ("p3_sgg", "p3_sge", "p3_see", "p3_syy", "p3_sgy", "p3_sye")
        )
        yield "p3_det", ((sgg, syy), (sgy, sgy)), 0
        yield "p3_nu", ((syy, sge), (sgy, sye)), 0
        yield "p3_nv", ((sgg, sye), (sgy, sge)), 0
        det, nu, nv = f["p3_det"], f["p3_nu"], f["p3_nv"]
        yield "p3_res", ((see, det), (sge, nu), (sye, nv)), 0
        yield "p3_res", ((f["p3_tr2"], det),), 0

    def _box_intermediates(self, level: FixedFormat) -> Iterable[tuple[str, Terms, int]]:
        """The box form's exact sums: ``gy``, the five box sums, ``bdet``, ``bnv``,
        ``e + gy v`` and the 1-D window's row passes on it."""
        f = self.formats
        yield "p3_grad", ((level,), (level,), (f["p3_warp"],), (f["p3_warp"],)), 1
        yield "p3_gy", ((f["p3_grad"],), (f["p3_grad"],)), 1
        g, gy, e = f["p3_g"], f["p3_gy"], f["p3_e"]
        box = (2 * self.vertical_radius + 1) ** 2
        for name, p, q in (("p3_bgg", g, g), ("p3_bge", g, e), ("p3_byy", gy, gy),
                           ("p3_bgy", g, gy), ("p3_bye", gy, e)):  # fmt: skip
            yield name, ((p, q),) * box, 0
        bgg, bge, byy, bgy, bye = (f[s] for s in ("p3_bgg", "p3_bge", "p3_byy", "p3_bgy", "p3_bye"))
        yield "p3_bdet", ((bgg, byy), (bgy, bgy)), 0
        yield "p3_bnv", ((bgg, bye), (bgy, bge)), 0
        yield "p3_ev", ((e,), (gy, f["p3_v"])), 0
        taps, win, ev = 2 * self.radius + 1, f["p3_win"], f["p3_ev"]
        yield "p3_rge", ((win, g, ev),) * taps, 0
        yield "p3_ree", ((win, ev, ev),) * taps, 0

    def divider_intermediates(self) -> Iterable[tuple[str, int, str]]:
        f = self.formats
        window = self.vertical_form == "window"
        du = ("p3_du", "p3_nu", "p3_det") if window else ("p3_du", "p3_sge", "p3_sgg")
        quotients = [du, ("p3_range", "p3_fb", "p3_u")]
        if self.vertical_form == "box":
            quotients.append(("p3_v", "p3_bnv", "p3_bdet"))
        for out, num, den in quotients:
            n, d, q = f[num], f[den], f[out]
            if self.divider == "restoring":
                need = signed_bits(n) + max(0, q.frac + 1 + d.frac - n.frac) + 1
                need = max(need, signed_bits(d) + max(0, n.frac - q.frac - 1 - d.frac), q.word + 3)
            else:
                need = max(signed_bits(n) + self.recip_bits + 2, 2 * (self.recip_bits + 2))
            yield out, need, f"{self.divider} divider"


#: P3 signals in datapath order.
P3_SIGNALS: tuple[str, ...] = P3Config.signals()
