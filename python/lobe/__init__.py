"""lobe: evaluate BRDFs with Vulkan compute shaders (GLSL, f32), checked against an f64 CPU
reference: f at direction pairs, lobe tables, albedo and look-up tables as numpy arrays.

Conventions: local frame n = +z, t = +x, b = +y; w = (sin t cos p, sin t sin p, cos t); wi
points to the light, wo to the viewer; f is in 1/sr, linear RGB, without the cosine, and 0
whenever wi or wo is below the horizon. Angles are in radians.

    >>> import lobe
    >>> s = lobe.Session(backend="cpu")
    >>> s.eval("lambert", [0, 0, 1], [0, 0, 1], params={"albedo": 0.5})
    array([0.15915494, 0.15915494, 0.15915494])
"""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass
from typing import Any, Dict, List, Mapping, NamedTuple, Optional, Sequence, Tuple, Union

import numpy as np

from . import _lobe
from ._lobe import GpuError, InvalidValuesError

__all__ = [
    "Session",
    "models",
    "parity_tolerance",
    "GpuError",
    "InvalidValuesError",
    "Table",
    "Albedo",
    "HemisphericalAlbedo",
    "AlbedoLut",
    "EngineLut",
    "FitResult",
    "Samples",
]

try:
    from importlib.metadata import version as _version

    __version__ = _version("lobe")
except Exception:  # an uninstalled source tree has no metadata
    __version__ = "unknown"

#: A direction may differ from unit length by this much: f32 directions written out with 7
#: digits are unit only to about 1e-7, and anything further off is a mistake, not rounding.
UNIT_LENGTH_TOLERANCE = 1e-5

#: The largest table :meth:`Session.table` builds in memory (12 bytes a cell: 1.5 GiB).
MAX_TABLE_CELLS = 1 << 27

#: The most draws one :meth:`Session.sample` makes (``lobe sample -n``'s bound, 2^22).
MAX_SAMPLE_DRAWS = 1 << 22

ParamValue = Union[float, int, bool, str, Sequence[float]]
Params = Mapping[str, ParamValue]


def models() -> List[Dict[str, Any]]:
    """Every built-in model with its parameters, as plain data.

    Each entry is ``{"name", "description", "delta_lobe", "parameters"}``; each parameter is
    ``{"key", "kind" ("rgb", "scalar", "choice" or "flag"), "range", "default",
    "description"}`` (the catalogue ``lobe models --format json`` prints).
    """
    return json.loads(_lobe.models_json())["models"]


def materials() -> List[str]:
    """The names of the material presets ``material=`` takes."""
    return json.loads(_lobe.models_json())["materials"]


def _value_text(key: str, value: ParamValue) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, (int, float, np.integer, np.floating)):
        return repr(float(value))
    if isinstance(value, str):
        return value
    try:
        numbers = [float(v) for v in value]  # type: ignore[union-attr]
    except (TypeError, ValueError):
        raise ValueError(
            f"params: parameter '{key}' = {value!r}: expected a number, three numbers "
            "(r, g, b) or the name of an option"
        ) from None
    return ",".join(repr(v) for v in numbers)


def _sets(params: Optional[Params]) -> List[str]:
    if params is None:
        return []
    if not isinstance(params, Mapping):
        raise TypeError(f"params: expected a dict of parameter values, got {type(params).__name__}")
    return [f"{k}={_value_text(k, v)}" for k, v in params.items()]


def _sets_list(params: Union[None, Params, Sequence[Params]]) -> Tuple[List[List[str]], bool]:
    """KEY=VALUE texts per parameter set, and whether a list of sets was given."""
    if params is None or isinstance(params, Mapping):
        return [_sets(params)], False
    sets = list(params)
    if not sets:
        raise ValueError("params: an empty list of parameter sets")
    return [_sets(p) for p in sets], True


def _model(model: Union[str, os.PathLike]) -> str:
    if isinstance(model, os.PathLike):
        return os.fspath(model)
    if not isinstance(model, str):
        raise TypeError(f"model: expected a model name or a path, got {type(model).__name__}")
    return model


def _reals(name: str, value: Any) -> np.ndarray:
    """``value`` as an array of real numbers: what ``np.asarray(value, dtype=float)`` takes
    (floats, integers and booleans, in arrays, lists or scalars), float32 kept as it is and
    the rest as float64; text, complex numbers, ragged lists and other objects are refused
    naming ``name``."""
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as e:
        raise TypeError(f"{name}: expected real numbers, got {type(value).__name__}: {e}") from None
    if arr.dtype.kind == "O":
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise TypeError(f"{name}: expected real numbers: {e}") from None
    if arr.dtype.kind not in "fiub":
        raise TypeError(f"{name}: expected real numbers (float, int or bool), got dtype {arr.dtype}")
    return arr if arr.dtype == np.float32 else arr.astype(np.float64, copy=False)


def _directions(name: str, value: Any) -> np.ndarray:
    """A float array of shape (..., 3) of unit vectors, or a refusal naming ``name``."""
    arr = _reals(name, value)
    if arr.ndim == 0 or arr.shape[-1] != 3:
        raise ValueError(f"{name}: expected shape (..., 3) (x, y, z in lobe's frame), got {arr.shape}")
    finite = np.isfinite(arr).all(axis=-1)
    if not finite.all():
        at = tuple(int(i) for i in np.argwhere(~finite)[0])
        raise ValueError(f"{name}: the direction at index {at} is {arr[at].tolist()}; NaN and infinities are refused")
    length = np.sqrt((arr.astype(np.float64) ** 2).sum(axis=-1))
    off = np.abs(length - 1.0) > UNIT_LENGTH_TOLERANCE
    if off.any():
        at = tuple(int(i) for i in np.argwhere(off)[0])
        raise ValueError(
            f"{name}: the direction at index {at} has length {float(length[at]):.6g}; "
            f"directions must be unit vectors (within {UNIT_LENGTH_TOLERANCE})"
        )
    return arr


def _pairs(wi: Any, wo: Any) -> Tuple[np.ndarray, np.ndarray, Tuple[int, ...]]:
    a, b = _directions("wi", wi), _directions("wo", wo)
    try:
        a, b = np.broadcast_arrays(a, b)
    except ValueError:
        raise ValueError(f"wi, wo: shapes {a.shape} and {b.shape} do not broadcast together") from None
    shape = a.shape[:-1]
    flat = lambda x: np.ascontiguousarray(x.reshape(-1, 3), dtype=np.float64)
    return flat(a), flat(b), shape


def _positive_ints(name: str, value: Any, count: Optional[int] = None) -> List[int]:
    values = [value] if isinstance(value, (int, np.integer)) else list(value)
    if not all(isinstance(v, (int, np.integer)) and not isinstance(v, bool) and v > 0 for v in values):
        raise ValueError(f"{name}: expected positive integers, got {value!r}")
    if count is not None and len(values) != count:
        raise ValueError(f"{name}: expected {count} positive integers, got {value!r}")
    return [int(v) for v in values]


def _finite(name: str, value: Any) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise TypeError(f"{name}: expected a number, got {value!r}") from None
    if not math.isfinite(v):
        raise ValueError(f"{name}: {v} is not a finite number")
    return v


class Table(NamedTuple):
    """A lobe table: ``values`` (float32, the shape of the ``.npy`` lobe writes: one axis per
    angle in ``res`` order, then RGB) and ``axes``, each axis's name with its cell-centred
    angles in radians, in the order of the array's axes."""

    values: np.ndarray
    axes: Dict[str, np.ndarray]

    def __array__(self, dtype=None, copy=None):
        """``np.asarray(table)`` is ``table.values`` (a copy only where ``dtype`` or ``copy``
        asks for one)."""
        if copy is False and dtype is not None and np.dtype(dtype) != self.values.dtype:
            raise ValueError(f"a Table holds {self.values.dtype}; converting to {np.dtype(dtype)} needs a copy")
        if dtype is not None:
            return self.values.astype(dtype)
        return self.values.copy() if copy else self.values


class Albedo(NamedTuple):
    """Directional albedo E(mu) with its error estimate, each of shape (..., 3)."""

    albedo: np.ndarray
    error: np.ndarray


@dataclass(frozen=True)
class HemisphericalAlbedo:
    """Hemispherical albedo and Kulla–Conty's E_avg, each an RGB array of shape (3,)."""

    albedo: np.ndarray
    error: np.ndarray
    delta: np.ndarray
    e_avg: np.ndarray
    e_avg_error: np.ndarray
    directions: int
    samples: int
    stopped_short: bool = False


@dataclass(frozen=True)
class AlbedoLut:
    """An albedo look-up table: ``e[k, j]`` = E(mu_j, p_k) (RGB), ``e_avg[k]`` = E_avg(p_k)."""

    e: np.ndarray
    e_avg: np.ndarray
    mu: np.ndarray
    p: np.ndarray
    e_error: np.ndarray
    e_avg_error: np.ndarray
    max_error: float
    keys: List[str]
    mapping: str


@dataclass(frozen=True)
class EngineLut:
    """A real-time engine's table: ``values[k, j, c]`` is channel c at (mu_j, p_k)."""

    values: np.ndarray
    avg: np.ndarray
    mu: np.ndarray
    p: np.ndarray
    axis: np.ndarray
    error: np.ndarray
    avg_error: np.ndarray
    max_error: float
    channels: List[str]


@dataclass(frozen=True)
class FitResult:
    """A fit: the fitted ``params`` (every parameter of ``model``), the ``loss`` and its value per
    channel (``channel_loss``, RGB), and the whole ``report`` ``lobe fit --format json`` prints."""

    model: str
    params: Dict[str, Any]
    free: List[str]
    loss: float
    channel_loss: np.ndarray
    report: Dict[str, Any]


class Samples(NamedTuple):
    """Draws of a model's sampler for one wo (:meth:`Session.sample`): ``wi`` and ``weight`` of
    shape (n, 3), ``pdf`` and ``delta`` (bool, the mirror spike of a layered model, whose pdf is
    its probability) of shape (n,); a lost draw keeps its wi below the horizon with weight and
    pdf 0."""

    wi: np.ndarray
    weight: np.ndarray
    pdf: np.ndarray
    delta: np.ndarray



def _env(env):
    """An environment map argument as (name or path, None) or (None, an (H, W, 3) float32 array)."""
    if isinstance(env, (str, os.PathLike)):
        return os.fspath(env), None
    array = np.asarray(env)
    if array.ndim != 3 or array.shape[2] != 3 or not np.issubdtype(array.dtype, np.number):
        raise ValueError(f"env: expected a map name, a path or an (H, W, 3) array of radiance, got shape {array.shape}")
    return None, np.ascontiguousarray(array, dtype=np.float32)

class Session:
    def __init__(self, backend: str = "gpu", device: Optional[str] = None) -> None:
        if device is not None and not isinstance(device, str):
            raise TypeError(f"device: expected a device name or None, got {type(device).__name__}")
        self._s = _lobe._Session(backend, device)

    def __repr__(self) -> str:
        return f"lobe.Session({self.backend!r})"

    @property
    def backend(self) -> str:
        """'gpu (device name)' or 'cpu (f64 reference)'."""
        return self._s.backend_name()

    def eval(self, model, wi, wo, params=None, material=None, white_furnace=False):
        wi_flat, wo_flat, shape = _pairs(wi, wo)
        sets_list, many = _sets_list(params)
        out = self._s.eval(_model(model), material, sets_list, bool(white_furnace), wi_flat, wo_flat)
        out = out.reshape((len(sets_list),) + shape + (3,))
        return out if many else out[0]

    def table(self, model, grid="full", res=None, params=None, material=None, white_furnace=False,
              max_cells=MAX_TABLE_CELLS):
        if res is None:
            raise ValueError("res: give the cells per axis, e.g. res=(90, 90, 180) for grid='isotropic'")
        values, axes = self._s.table(_model(model), material, _sets(params), bool(white_furnace),
                                     grid, _positive_ints("res", res), int(max_cells))
        return Table(values, dict(axes))

    def write_table(self, path, model, grid="full", res=None, params=None, material=None,
                    white_furnace=False, allow_invalid=False):
        if res is None:
            raise ValueError("res: give the cells per axis, e.g. res=(90, 90, 180) for grid='isotropic'")
        return self._s.write_table(_model(model), material, _sets(params), bool(white_furnace), grid,
                                   _positive_ints("res", res), os.fspath(path), bool(allow_invalid))

    def albedo(self, model, mu, params=None, material=None, white_furnace=False, phi=0.0,
               method="peak", samples=None, seed=0):
        mu_arr = _reals("mu", mu)
        bad = ~((mu_arr > 0.0) & (mu_arr <= 1.0))
        if bad.any():
            at = tuple(int(i) for i in np.argwhere(bad)[0]) if mu_arr.ndim else ()
            raise ValueError(f"mu: {float(mu_arr[at])} at index {at} is out of range; mu = cos(theta_o) must be in (0, 1]")
        sets_list, many = _sets_list(params)
        albedo, error = self._s.albedo(_model(model), material, sets_list, bool(white_furnace),
                                       mu_arr.reshape(-1).tolist(), _finite("phi", phi), method,
                                       _samples(samples), _seed(seed))
        shape = (len(sets_list),) + mu_arr.shape + (3,)
        albedo, error = albedo.reshape(shape), error.reshape(shape)
        return Albedo(albedo, error) if many else Albedo(albedo[0], error[0])

    def hemispherical_albedo(self, model, params=None, material=None, white_furnace=False, phi=0.0,
                             method="peak", samples=None, seed=0):
        sets_list, many = _sets_list(params)
        rows = self._s.hemispherical_albedo(_model(model), material, sets_list, bool(white_furnace),
                                            _finite("phi", phi), method, _samples(samples),
                                            _seed(seed))
        out = [HemisphericalAlbedo(**{k: (np.array(v) if isinstance(v, list) else v) for k, v in r.items()})
               for r in rows]
        return out if many else out[0]

    def albedo_lut(self, model, params=None, material=None, white_furnace=False, param=None,
                   range=None, res=(32, 32), mapping=None, method="peak", samples=None, phi=0.0,
                   with_avg=True, seed=0):
        keys = [param] if isinstance(param, str) else (None if param is None else list(param))
        lo_hi = None if range is None else tuple(_finite("range", v) for v in range)
        if lo_hi is not None and len(lo_hi) != 2:
            raise ValueError(f"range: expected (lo, hi), got {range!r}")
        d = _lobe.albedo_lut(self._s, _model(model), material, _sets(params), bool(white_furnace), keys,
                             lo_hi, tuple(_positive_ints("res", res, 2)), mapping, method,
                             _samples(samples), _seed(seed), _finite("phi", phi), bool(with_avg))
        return AlbedoLut(**d)

    def engine_lut(self, kind="dfg", res=(32, 32), params=None, method="peak", samples=None, seed=0):
        d = _lobe.engine_lut(self._s, kind, _sets(params), tuple(_positive_ints("res", res, 2)),
                             method, _samples(samples), _seed(seed))
        return EngineLut(**d)


    def fit(self, target, model, free, params=None, target_params=None, loss="log",
            max_bins=65536, starts=4, max_iters=400):
        if isinstance(free, str):
            free = [free]
        report = json.loads(_lobe.fit(self._s, _model(target), _sets(target_params), _model(model),
                                      _sets(params), [str(k) for k in free], loss,
                                      _positive_ints("max_bins", max_bins, 1)[0],
                                      _positive_ints("starts", starts, 1)[0],
                                      _positive_ints("max_iters", max_iters, 1)[0]))
        return FitResult(model=report["model"], params=report["parameters"], free=report["free"],
                         loss=report["loss"]["total"], channel_loss=np.array(report["loss"]["channel"]),
                         report=report)


    def chi2(self, model, wo=None, params=None, material=None, samples=1 << 24, seed=0,
             theta_o_deg=None, phi_o_deg=0.0, significance=0.01, white_furnace=False,
             checked_draws=1 << 24):
        if wo is not None and theta_o_deg is not None:
            raise ValueError("wo and theta_o_deg: give the view directions one way, not both")
        if wo is not None:
            wo_arr = _directions("wo", wo).astype(np.float64).reshape(-1, 3)
            if wo_arr.shape[0] == 0:
                raise ValueError("wo: expected at least one view direction")
            below = wo_arr[:, 2] <= 0.0
            if below.any():
                k = int(np.argmax(below))
                raise ValueError(f"wo: the direction at index {k} is {wo_arr[k].tolist()}; view directions must lie above the horizon (z > 0)")
            thetas = [float(np.degrees(np.arccos(min(z, 1.0)))) for z in wo_arr[:, 2]]
            phis = [float(np.degrees(np.arctan2(y, x))) for x, y in wo_arr[:, :2]]
        else:
            if theta_o_deg is None:
                theta_o_deg = (0.0, 30.0, 60.0, 85.0)
            thetas = [float(t) for t in _reals("theta_o_deg", theta_o_deg).reshape(-1)]
            phis = [_finite("phi_o_deg", phi_o_deg)] * len(thetas)
        for k, t in enumerate(thetas):
            if not (0.0 <= t < 90.0):
                raise ValueError(f"theta_o_deg: {t} at index {k} is out of range; view angles must be in [0, 90) degrees")
        significance = _finite("significance", significance)
        if not (0.0 < significance < 1.0):
            raise ValueError(f"significance: {significance} is out of range; expected a probability in (0, 1)")
        samples = _positive_ints("samples", samples, 1)[0]
        seed = _seed(seed)
        if checked_draws is not None:
            checked_draws = _positive_ints("checked_draws", checked_draws, 1)[0]
        return json.loads(_lobe.chi2(self._s, _model(model), material, _sets(params), bool(white_furnace),
                                     thetas, phis, samples, seed, significance, checked_draws))

    def light(self, model, env, size=256, params=None, material=None, method="exact"):
        if method not in ("exact", "split_sum"):
            raise ValueError(f"method: {method!r}; expected \"exact\" (the sum over every texel) or \"split_sum\" (Karis' split sum)")
        size = _positive_ints("size", size, 1)[0]
        name, array = _env(env)
        return _lobe.light(self._s, _model(model), material, _sets(params), name, array, size, method)

    def light_report(self, model, env, size=64, steps=9, params=None, material=None, white_furnace=False):
        """The split sum's error against the exact sum over `steps` values of the model's
        roughness, as `lobe light --report` computes it: a dict with "parameter" (the swept key)
        and "rows", one dict per value with the report CSV's columns (docs/commands.md)."""
        size = _positive_ints("size", size, 1)[0]
        steps = _positive_ints("steps", steps, 1)[0]
        name, array = _env(env)
        return json.loads(_lobe.light_report(self._s, _model(model), material, _sets(params), bool(white_furnace),
                                             name, array, size, steps))

    def sample(self, model, wo, n, params=None, material=None, seed=0, white_furnace=False):
        wo_arr = _directions("wo", wo)
        if wo_arr.shape != (3,):
            raise ValueError(f"wo: expected one direction of shape (3,), got {wo_arr.shape}")
        count = _positive_ints("n", n, 1)[0]
        if count > MAX_SAMPLE_DRAWS:
            raise ValueError(f"n: {count} draws: expected from 1 to {MAX_SAMPLE_DRAWS} (2^22) draws per request")
        seed = _seed(seed)
        wi, weight, pdf, delta = _lobe.sample(self._s, _model(model), material, _sets(params), bool(white_furnace),
                                              [float(v) for v in wo_arr], count, seed)
        return Samples(wi, weight, pdf, delta)

    def pdf(self, model, wi, wo, params=None, material=None, white_furnace=False):
        wi_flat, wo_flat, shape = _pairs(wi, wo)
        out = _lobe.pdf(self._s, _model(model), material, _sets(params), bool(white_furnace), wi_flat, wo_flat)
        return out.reshape(shape)

    def compare(self, a, b, params_a=None, params_b=None, grid=None, res=None, mu=(0.1, 0.5, 1.0),
                method="peak", samples=None, albedo=True, white_furnace=False):
        mus = [float(m) for m in _reals("mu", mu).reshape(-1)]
        for k, m in enumerate(mus):
            if not (0.0 < m <= 1.0):
                raise ValueError(f"mu: {m} at index {k} is out of range; mu = cos(theta_o) must be in (0, 1]")
        res_list = None if res is None else _positive_ints("res", res)
        if res_list is not None and grid is None:
            raise ValueError("res: give grid= with it (the grid the resolution is for)")
        return json.loads(_lobe.compare(self._s, _model(a), _sets(params_a), _model(b), _sets(params_b),
                                        grid, res_list, mus, method, _samples(samples), bool(albedo),
                                        bool(white_furnace)))


def _seed(seed: Any) -> int:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)):
        raise TypeError(f"seed: expected an integer from 0 to 2^32 - 1, got {seed!r}")
    seed = int(seed)
    if not (0 <= seed < 2**32):
        raise ValueError(f"seed: {seed} is out of range; expected an integer from 0 to 2^32 - 1")
    return seed


def _samples(samples: Any) -> Optional[int]:
    return None if samples is None else _positive_ints("samples", samples, 1)[0]


def parity_tolerance(model, wi, wo, params=None, material=None, white_furnace=False):
    wi_flat, wo_flat, shape = _pairs(wi, wo)
    out = _lobe.parity_tolerance(_model(model), material, _sets(params), bool(white_furnace), wi_flat, wo_flat)
    return out.reshape(shape + (3,))


def _attach_docs() -> None:
    """Docstrings live once, in the stub (``__init__.pyi``); ``help()`` reads them from there."""
    import ast

    stub = os.path.join(os.path.dirname(__file__), "__init__.pyi")
    try:
        with open(stub, encoding="utf-8") as f:
            tree = ast.parse(f.read())
    except OSError:
        return
    scope = globals()
    for node in tree.body:
        if isinstance(node, ast.FunctionDef) and node.name in scope:
            doc = ast.get_docstring(node)
            if doc and not scope[node.name].__doc__:
                scope[node.name].__doc__ = doc
        if isinstance(node, ast.ClassDef) and node.name == "Session":
            Session.__doc__ = ast.get_docstring(node)
            for item in node.body:
                if isinstance(item, ast.FunctionDef) and hasattr(Session, item.name):
                    doc = ast.get_docstring(item)
                    member = getattr(Session, item.name)
                    if doc and isinstance(member, type(_attach_docs)) and not member.__doc__:
                        member.__doc__ = doc


_attach_docs()
