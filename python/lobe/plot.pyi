"""Pictures of a lobe, drawn by lobe itself (no matplotlib needed)."""

import os
from typing import Any, Mapping, Optional, Sequence, Union

from . import ModelSpec, Params, Session

class Figure:
    """A picture lobe drew: ``svg`` is its SVG text and ``title`` its title; ``save(path)``
    writes it as .svg, .png or .pdf (by the extension); Jupyter shows it inline."""

    svg: str
    title: str
    def save(self, path: Union[str, os.PathLike[str]]) -> None:
        """Writes the picture; the format follows the extension (.svg, .png, .pdf)."""
    def _repr_svg_(self) -> str: ...
    def _repr_png_(self) -> bytes: ...

def polar(session: Session, models: Union[ModelSpec, Sequence[ModelSpec]],
          material: Optional[str] = None, params: Optional[Params] = None,
          theta_i_deg: Optional[Sequence[float]] = None, log: bool = False, cos: bool = False,
          white_furnace: bool = False, channel: str = "luminance") -> Figure:
    """Polar plot of f in the plane of incidence (``lobe plot polar``), one curve per incidence
    angle ``theta_i_deg`` (default 0, 30, 60, 80 degrees) and model. ``log``: logarithmic
    radius; ``cos``: f cos(theta_i); ``channel``: luminance, r, g or b."""

def hemisphere(session: Session, models: Union[ModelSpec, Sequence[ModelSpec]],
               material: Optional[str] = None, params: Optional[Params] = None,
               theta_i_deg: Optional[Sequence[float]] = None, cos: bool = False,
               white_furnace: bool = False, channel: str = "luminance") -> Figure:
    """Heat map of f over the view hemisphere (``lobe plot hemisphere``, equal-area projection,
    logarithmic colours), one panel per incidence angle and model."""

def albedo(session: Session, models: Union[ModelSpec, Sequence[ModelSpec]],
           material: Optional[str] = None, params: Optional[Params] = None,
           white_furnace: bool = False, channel: str = "luminance",
           method: str = "peak") -> Figure:
    """Directional albedo curves E(mu) of each model (``lobe plot albedo``)."""
