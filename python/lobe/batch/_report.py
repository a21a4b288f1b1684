"""The report of a fit batch: materials (rows) against models (columns), the loss of each pair,
the best model of each material marked; as text, and as a heat map (SVG, or PNG rasterised
by lobe's own renderer as its other pictures are)."""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from typing import Dict, List, Mapping, Optional, Sequence, Tuple
from xml.sax.saxutils import escape

from ._ledger import BatchError, write_atomic

#: The colour map of lobe's heat maps (``colour_map`` in src/plot/canvas/palette.rs, the same
#: anchors): matplotlib's viridis at t = 0, 1/8, ..., 1 (sRGB 8-bit), interpolated linearly.
RAMP = ((68, 1, 84), (71, 44, 122), (59, 81, 139), (44, 113, 142), (33, 145, 140),
        (39, 173, 129), (92, 200, 99), (170, 220, 50), (253, 231, 37))

# The picture's layout, in pixels: cells, the label columns and rows, text size.
CELL_W, CELL_H, FONT = 120, 34, 13


def _label(row: Mapping[str, str]) -> str:
    return f"{row['model']} [{row['free']}]"


@dataclass
class Matrix:
    """Loss per (material, model); NaN where a pair has no row."""

    materials: List[str]
    models: List[str]
    loss: List[List[float]]

    @classmethod
    def of(cls, rows: Sequence[Mapping[str, str]]) -> "Matrix":
        if not rows:
            raise BatchError("report: the CSV has no rows yet")
        materials: Dict[str, None] = {}
        models: Dict[str, None] = {}
        cells: Dict[Tuple[str, str], float] = {}
        for r in rows:
            materials.setdefault(r["target"])
            models.setdefault(_label(r))
            cells.setdefault((r["target"], _label(r)), float(r["loss"]))
        mats, mods = list(materials), list(models)
        return cls(mats, mods, [[cells.get((m, k), math.nan) for k in mods] for m in mats])

    def best(self, i: int) -> Optional[int]:
        row = [(v, j) for j, v in enumerate(self.loss[i]) if not math.isnan(v)]
        return min(row)[1] if row else None

    def text(self) -> str:
        """The table as aligned text: a row per material, a column per model, ``*`` at each
        row's lowest loss, ``-`` where a pair has no row."""
        head = ["material"] + self.models + ["best"]
        body = []
        for i, m in enumerate(self.materials):
            b = self.best(i)
            cells = ["-" if math.isnan(v) else f"{v:.4g}{'*' if j == b else ''}"
                     for j, v in enumerate(self.loss[i])]
            body.append([m] + cells + ["-" if b is None else self.models[b]])
        widths = [max(len(r[c]) for r in [head] + body) for c in range(len(head))]
        lines = ["  ".join(x.ljust(w) if c == 0 or c == len(head) - 1 else x.rjust(w)
                           for c, (x, w) in enumerate(zip(r, widths))).rstrip()
                 for r in [head] + body]
        return "\n".join(lines) + "\n"


def colour_map(t: float) -> str:
    """The colour at t in [0, 1] (clamped; 0 for NaN), as lobe's ``colour_map`` gives it."""
    t = min(max(t, 0.0), 1.0) * (len(RAMP) - 1) if math.isfinite(t) else 0.0
    k = min(int(t), len(RAMP) - 2)
    f = t - k
    # Halves round away from zero, as Rust's f64::round does.
    rgb = [int(math.floor(a + (b - a) * f + 0.5)) for a, b in zip(RAMP[k], RAMP[k + 1])]
    return "#%02x%02x%02x" % tuple(rgb)


def _short(text: str, chars: int) -> str:
    return text if len(text) <= chars else text[:chars - 1] + "…"


#: The width of a character of the labels, a little over DejaVu Sans's mean advance (0.55 em),
#: so that a label is never wider than the room it gets.
CHAR_W = 0.6 * FONT
#: The longest labels kept whole: a material's (rows), a model's (columns).
ROW_CHARS, COLUMN_CHARS = 48, 60


def svg(m: Matrix) -> Tuple[str, int, int]:
    """The heat map as SVG text, with its width and height: colour by log10 of the loss over
    the table's range, the value in each cell, the best model of each material outlined."""
    rows = [_short(os.path.basename(x) or x, ROW_CHARS) for x in m.materials]
    columns = [_short(x, COLUMN_CHARS) for x in m.models]
    title = "Fit loss per material and model"
    subtitle = "outlined: the best model of each material; colour: log10 of the loss"
    label_w = round(CHAR_W * max(len(r) for r in rows)) + 24
    top = 64 + round(CHAR_W * max(len(c) for c in columns))
    width = max(label_w + CELL_W * len(m.models) + 20, round(CHAR_W * len(subtitle)) + 40)
    height = top + CELL_H * len(m.materials) + 40
    logs = [math.log10(v) for row in m.loss for v in row if v > 0 and not math.isnan(v)]
    lo, hi = (min(logs), max(logs)) if logs else (0.0, 1.0)
    span = hi - lo if hi > lo else 1.0
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{width}" height="{height}" '
           f'viewBox="0 0 {width} {height}" font-family="DejaVu Sans" font-size="{FONT}">',
           f'<rect width="{width}" height="{height}" fill="white"/>',
           f'<text x="10" y="24" font-size="17" font-weight="bold">{title}</text>',
           f'<text x="10" y="46">{subtitle}</text>']
    for j, name in enumerate(columns):
        x = label_w + CELL_W * j + CELL_W / 2 + FONT / 3
        out.append(f'<text transform="translate({x:.1f},{top - 8}) rotate(-90)">{escape(name)}</text>')
    for i, mat in enumerate(m.materials):
        y = top + CELL_H * i
        out.append(f'<text x="{label_w - 10}" y="{y + CELL_H / 2 + FONT / 3:.1f}" text-anchor="end">'
                   f'{escape(rows[i])}</text>')
        b = m.best(i)
        for j, v in enumerate(m.loss[i]):
            x = label_w + CELL_W * j
            if math.isnan(v):
                out.append(f'<rect x="{x}" y="{y}" width="{CELL_W}" height="{CELL_H}" fill="#eeeeee" '
                           'stroke="white"/>')
                continue
            t = (math.log10(v) - lo) / span if v > 0 else 0.0
            ink = "white" if t < 0.6 else "black"
            out.append(f'<rect x="{x}" y="{y}" width="{CELL_W}" height="{CELL_H}" fill="{colour_map(t)}" '
                       'stroke="white"/>')
            out.append(f'<text x="{x + CELL_W / 2}" y="{y + CELL_H / 2 + FONT / 3:.1f}" '
                       f'text-anchor="middle" fill="{ink}"'
                       f'{" font-weight=" + chr(34) + "bold" + chr(34) if j == b else ""}>{v:.4g}</text>')
        if b is not None:
            x = label_w + CELL_W * b
            out.append(f'<rect x="{x + 2}" y="{y + 2}" width="{CELL_W - 4}" height="{CELL_H - 4}" '
                       'fill="none" stroke="#e8112d" stroke-width="3"/>')
    out.append(f'<text x="10" y="{height - 14}" font-size="11">log10 of the loss from '
               f'{lo:.3g} (dark) to {hi:.3g} (light)</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n", width, height


def draw(m: Matrix, path: str) -> None:
    """Writes the heat map to ``path`` (``.svg`` or ``.png``), whole or not at all."""
    text, width, height = svg(m)
    lower = path.lower()
    if lower.endswith(".svg"):
        data = text.encode("utf-8")
    elif lower.endswith(".png"):
        from .. import _lobe

        data = bytes(_lobe.rasterise_svg(text, width, height))
    else:
        raise BatchError(f"-o {path}: give a .png or .svg file for the heat map")
    write_atomic(path, data)
