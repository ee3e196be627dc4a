"""The concentration mode's colour bar (issue 24): its layout in the frame and the panel's
ticks and labels, drawn on the CPU (Pillow) into an RGBA8 image.

The draw system (:meth:`riverflow.systems.draw.DrawRivers`) uploads the image when the frame's
size or the range changes and draws it in the frame's lower right corner with
``shaders/legend.glsl``, whose bar is coloured by ``spill.glsl``'s ``concentration_ramp``: the
water's own ramp, so the bar cannot disagree with the water. No GL here.

Layout (pixels, origin at the frame's lower left, rows upwards as in GL): a translucent dark
panel; in it the bar (low concentrations at the bottom), a white tick left of it at each
decade of ``concentration_range_kg_m3`` with its value in kg/m³ (``1e-4``), the unit above (kg/m3).
Pixel row ``j`` of the bar shows log10(c) = lo + (j + ½) / bar height · (hi − lo).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

UNIT = "kg/m3"
"""The unit written above the bar (Pillow's default font has no superscript three)."""
MIN_FRAME_HEIGHT_PX = 40
"""No legend in frames lower than this."""


@dataclass(frozen=True)
class ConcentrationBar:
    """Where the legend goes in a frame and what it says (module docstring)."""

    panel_px: tuple[int, int, int, int]
    """(x0, y0, width, height) of the panel in the frame [px], origin lower left."""
    bar_px: tuple[int, int, int, int]
    """(x0, y0, width, height) of the colour bar in the panel [px]."""
    ticks: tuple[tuple[float, int], ...]
    """(concentration [kg/m³], row in the panel [px]) of each labelled tick."""
    range_kg_m3: tuple[float, float]
    font_px: int = 8

    def row_value(self, row: int) -> float:
        """The concentration [kg/m³] the bar shows at panel row ``row``."""
        lo, hi = (math.log10(v) for v in self.range_kg_m3)
        t = (row - self.bar_px[1] + 0.5) / self.bar_px[3]
        return 10.0 ** (lo + t * (hi - lo))


def _label(c: float) -> str:
    """``1e-4`` for 0.0001; ``2.5e-3`` for 0.0025."""
    mantissa, exponent = f"{c:.1e}".split("e")
    mantissa = mantissa.rstrip("0").rstrip(".")
    return f"{mantissa}e{int(exponent)}"


def _font(size_px: int):
    from PIL import ImageFont
    return ImageFont.load_default(size=size_px)


def concentration_bar(range_kg_m3: tuple[float, float], frame_px: tuple[int, int]
                      ) -> ConcentrationBar | None:
    """The legend's layout for a frame of ``frame_px`` (W, H); None if it is too small."""
    width, height = (int(v) for v in frame_px)
    if height < MIN_FRAME_HEIGHT_PX or width < 2 * MIN_FRAME_HEIGHT_PX:
        return None
    lo, hi = (float(v) for v in range_kg_m3)
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi):
        raise ValueError(f"concentration legend: the range must be 0 < low < high, got "
                         f"{range_kg_m3!r}")
    font_px = max(10, round(height / 50))
    margin = max(3, round(height / 90))
    bar_w = max(5, round(height / 70))
    bar_h = max(16, round(0.33 * height))
    tick_len = max(3, bar_w // 2)
    decades = max(1, round(math.log10(hi / lo)))
    values = [lo * (hi / lo) ** (k / decades) for k in range(decades + 1)]
    font = _font(font_px)
    label_w = max(font.getlength(_label(v)) for v in values)
    title_w = font.getlength(UNIT)
    pad = margin
    half = font_px // 2 + 1
    inner_w = int(math.ceil(max(label_w + 2 + tick_len + bar_w, title_w)))
    panel_w = pad + inner_w + pad
    panel_h = pad + half + bar_h + half + font_px + pad
    bar = (pad + inner_w - bar_w, pad + half, bar_w, bar_h)
    # the bar's row nearest each decade (row j shows t = (j + 1/2) / bar_h)
    ticks = tuple((v, bar[1] + min(max(int(round(k / decades * bar_h - 0.5)), 0), bar_h - 1))
                  for k, v in enumerate(values))
    x0 = width - margin - panel_w
    if x0 < 0:
        return None
    return ConcentrationBar((x0, margin, panel_w, panel_h), bar, ticks, (lo, hi), font_px)


def legend_panel_rgba(bar: ConcentrationBar) -> np.ndarray:
    """The panel (H, W, 4) uint8, row 0 at the bottom (GL's order): translucent black, the
    ticks and labels in white, the bar's place left transparent (the shader colours it)."""
    from PIL import Image, ImageDraw

    _, _, w, h = bar.panel_px
    bx, by, bw, bh = bar.bar_px
    image = Image.new("RGBA", (w, h), (0, 0, 0, 150))
    draw = ImageDraw.Draw(image)
    font = _font(bar.font_px)
    tick_len = max(3, bw // 2)
    top = lambda row: h - 1 - row                     # noqa: E731  (GL row → image row)
    for value, row in bar.ticks:
        y = top(row)
        draw.line([(bx - tick_len, y), (bx - 1, y)], fill=(255, 255, 255, 255))
        draw.text((bx - tick_len - 2, y), _label(value), fill=(255, 255, 255, 255), font=font,
                  anchor="rm")
    draw.text((bx + bw, top(by + bh) - 2), UNIT, fill=(255, 255, 255, 255), font=font,
              anchor="rb")
    out = np.asarray(image, np.uint8)[::-1].copy()
    out[by:by + bh, bx:bx + bw] = 0
    return out
