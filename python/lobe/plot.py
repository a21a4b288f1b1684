"""Pictures of a lobe, drawn by lobe itself (no matplotlib needed): each function returns a
:class:`Figure`, which Jupyter shows (``_repr_svg_``, ``_repr_png_``) and ``save`` writes."""

from __future__ import annotations

import os
import tempfile
from typing import Callable, Optional, Sequence, Union

from . import Session, _lobe, _model, _sets


class Figure:
    """A picture lobe drew: ``svg`` is its SVG text; ``save(path)`` writes it as .svg, .png or
    .pdf (by the extension, drawn again for PNG and PDF); Jupyter shows it inline."""

    def __init__(self, draw: Callable[[str], str]) -> None:
        self._draw = draw
        self.svg = self._render(".svg").decode("utf-8")

    def _render(self, suffix: str) -> bytes:
        with tempfile.TemporaryDirectory() as folder:
            path = os.path.join(folder, "figure" + suffix)
            self.title = self._draw(path)
            with open(path, "rb") as f:
                return f.read()

    def save(self, path: Union[str, os.PathLike]) -> None:
        path = os.fspath(path)
        if path.endswith(".svg"):
            with open(path, "w", encoding="utf-8") as f:
                f.write(self.svg)
        else:
            self._draw(path)

    def _repr_svg_(self) -> str:
        return self.svg

    def _repr_png_(self) -> bytes:
        return self._render(".png")

    def __repr__(self) -> str:
        return f"<lobe.plot.Figure: {self.title}>"


def _figure(session: Session, kind: str, models, material, params, theta_i_deg, log, cos,
            white_furnace, channel, method) -> Figure:
    if not isinstance(session, Session):
        raise TypeError(f"session: expected a lobe.Session, got {type(session).__name__}")
    specs = [_model(models)] if isinstance(models, (str, os.PathLike)) else [_model(m) for m in models]
    angles = None if theta_i_deg is None else [float(t) for t in theta_i_deg]
    sets = _sets(params)

    def draw(path: str) -> str:
        return _lobe.plot(session._s, kind, specs, material, sets, angles, bool(log), bool(cos),
                          bool(white_furnace), channel, method, path)

    return Figure(draw)


def polar(session: Session, models, material: Optional[str] = None, params=None,
          theta_i_deg: Optional[Sequence[float]] = None, log: bool = False, cos: bool = False,
          white_furnace: bool = False, channel: str = "luminance") -> Figure:
    return _figure(session, "polar", models, material, params, theta_i_deg, log, cos, white_furnace,
                   channel, "peak")


def hemisphere(session: Session, models, material: Optional[str] = None, params=None,
               theta_i_deg: Optional[Sequence[float]] = None, cos: bool = False,
               white_furnace: bool = False, channel: str = "luminance") -> Figure:
    return _figure(session, "hemisphere", models, material, params, theta_i_deg, True, cos,
                   white_furnace, channel, "peak")


def albedo(session: Session, models, material: Optional[str] = None, params=None,
           white_furnace: bool = False, channel: str = "luminance", method: str = "peak") -> Figure:
    return _figure(session, "albedo", models, material, params, None, False, False, white_furnace,
                   channel, method)


polar.__doc__ = """Polar plot of f in the plane of incidence, one curve per incidence angle
``theta_i_deg`` (default 0, 30, 60, 80 degrees) and model; ``models`` is one model spec or a list,
all with ``material`` and ``params``. ``log``: logarithmic radius; ``cos``: f cos(theta_i)."""
hemisphere.__doc__ = """Heat map of f over the view hemisphere (equal-area projection), one
panel per incidence angle and model, colours logarithmic."""
albedo.__doc__ = """Directional albedo curves E(mu) of each model, with ``method``'s error
estimates."""
