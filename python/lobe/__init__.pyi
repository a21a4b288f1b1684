"""lobe: BRDFs evaluated with Vulkan compute shaders (f32) or the f64 CPU reference, numpy in
and numpy out. Frame: n = +z, t = +x, b = +y; wi points to the light, wo to the viewer; f in
1/sr, linear RGB, without the cosine; angles in radians."""

import os
from dataclasses import dataclass
from typing import Any, Dict, List, Mapping, NamedTuple, Optional, Sequence, Tuple, Union, overload

import numpy as np
import numpy.typing as npt

__version__: str
UNIT_LENGTH_TOLERANCE: float
MAX_TABLE_CELLS: int
MAX_SAMPLE_DRAWS: int

ParamValue = Union[float, int, bool, str, Sequence[float]]
Params = Mapping[str, ParamValue]
ModelSpec = Union[str, os.PathLike[str]]
Directions = npt.ArrayLike

class GpuError(RuntimeError):
    """No usable Vulkan device, a lost device, or a Vulkan call that failed."""

class InvalidValuesError(ValueError):
    """The model gave NaN, infinite or negative values where the job needs valid ones."""

def models() -> List[Dict[str, Any]]:
    """Every built-in model with its parameters, as plain data.

    Each entry is ``{"name", "description", "delta_lobe", "parameters"}``; each parameter is
    ``{"key", "kind" ("rgb", "scalar", "choice" or "flag"), "range", "default",
    "description"}`` (what ``lobe models --format json`` prints).
    """

def materials() -> List[str]:
    """The names of the material presets that ``material=`` takes (tin, gold, ...)."""

def parity_tolerance(
    model: ModelSpec,
    wi: Directions,
    wo: Directions,
    params: Optional[Params] = None,
    material: Optional[str] = None,
    white_furnace: bool = False,
) -> np.ndarray:
    """The largest difference lobe allows between a GPU (f32) value and the f64 reference at each
    (wi, wo) pair, per channel, shape (..., 3): 1e-6 absolute, plus a relative part that grows
    with the model's exponent at the pair, plus how much the reference changes when a direction
    moves by a few f32 ulps (its conditioning). The test suite's GPU-vs-CPU parity bound."""

class Table(NamedTuple):
    """A lobe table.

    ``values``: float32, the shape of the ``.npy`` lobe writes, one axis per angle in ``res``
    order and then RGB. ``axes``: each angle axis's name with its cell-centred angles in radians,
    in the order of the array's axes. ``np.asarray(table)`` is ``table.values``.
    """

    values: np.ndarray
    axes: Dict[str, np.ndarray]
    def __array__(self, dtype: Any = None, copy: Optional[bool] = None) -> np.ndarray: ...

class Albedo(NamedTuple):
    """Directional albedo E(mu) (delta lobe included) and its estimated absolute error, each of
    shape mu.shape + (3,) (with a leading axis per parameter set when a list was given)."""

    albedo: np.ndarray
    error: np.ndarray

@dataclass(frozen=True)
class HemisphericalAlbedo:
    """Hemispherical albedo (1/pi) integral of E(wo) cos(theta_o) dwo, its delta-lobe part and
    error estimate, and Kulla-Conty's E_avg = 2 integral E(mu) mu dmu with its error estimate;
    each an RGB array of shape (3,). ``directions``: view directions integrated; ``samples``:
    integrand evaluations in all; ``stopped_short``: the reference spent its budget (or its
    panels' limit) before meeting its tolerance, and the values are as far as it got, within
    their error estimates."""

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
    """An albedo look-up table. ``e[k, j]``: E(mu_j, p_k), RGB, shape (Np, Nmu, 3);
    ``e_avg[k]``: E_avg(p_k), shape (Np, 3) (empty without ``with_avg``); ``mu``: the cell
    centres (j + 0.5)/Nmu; ``p``: each row's parameter value; ``e_error``, ``e_avg_error``: each
    entry's error estimate (largest channel); ``max_error``: the largest; ``keys``: the
    parameters set to p; ``mapping``: how rows map to p."""

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
    """A table a real-time engine loads. ``values[k, j, c]``: channel c (what each holds:
    ``channels``) at (mu_j, p_k), shape (Np, Nmu, channels); ``avg``: E_avg per row (empty for
    the DFG tables); ``p``: the model's parameter (alpha, or EON's r); ``axis``: the row's axis
    value before the mapping (perceptual roughness); ``error``, ``avg_error``, ``max_error``:
    error estimates."""

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
    """A fit: ``model``, the fitted ``params`` (every parameter, as ``lobe fit`` reports them),
    the ``free`` keys, the ``loss`` and its value per channel (``channel_loss``, RGB), and the
    whole ``report`` that ``lobe fit --format json`` prints (samples, albedo of target and fit,
    every start)."""

    model: str
    params: Dict[str, Any]
    free: List[str]
    loss: float
    channel_loss: np.ndarray
    report: Dict[str, Any]

class Samples(NamedTuple):
    """Draws of a model's sampler for one view direction wo, in draw order.

    ``wi``: (n, 3) directions towards the light (unit vectors). ``weight``: (n, 3)
    f(wi, wo) cos(theta_i) / pdf per linear RGB channel. ``pdf``: (n,) density over the solid
    angle of wi, in 1/sr. ``delta``: (n,) bool, True for the mirror spike of a layered model,
    whose wi is the mirror direction of wo, whose ``pdf`` is the probability of choosing the
    spike (not a density) and whose weight is the spike's albedo over that probability. A draw
    that leaves the upper hemisphere keeps its wi (wi[2] <= 0) with weight 0 and pdf 0.
    """

    wi: np.ndarray
    weight: np.ndarray
    pdf: np.ndarray
    delta: np.ndarray

class Session:
    """An open backend (a Vulkan device, or the f64 CPU reference) and the pipelines built on it.

    A model is a name (``"cook_torrance"``), a name with parameters (``"phong{shininess=50}"``),
    a BRDF Explorer ``.brdf`` file or a MERL ``.binary`` file. Parameters are applied in the
    command line's order: the model's defaults, then ``material=`` (a preset such as "gold"),
    then ``params`` (``{"alpha": 0.3, "specular": (1, .8, .3)}``), then the braces of the
    model's name. A refused parameter raises ValueError naming it and its valid range.

    The GIL is released while a job runs; Ctrl-C stops it (KeyboardInterrupt) with nothing
    partial kept, and also stops the jobs other threads run on the same session. One session
    may be used from several threads at once.
    """

    def __init__(self, backend: str = "gpu", device: Optional[str] = None) -> None:
        """Opens ``backend``: "gpu" (Vulkan compute in f32; a CPU driver such as lavapipe when
        there is no GPU) or "cpu" (the f64 reference, no Vulkan). ``device``: the first Vulkan
        device whose name contains this (case-insensitive). Raises GpuError when no device
        can be opened."""

    @property
    def backend(self) -> str:
        """'gpu (device name)' or 'cpu (f64 reference)'."""

    @overload
    def eval(self, model: ModelSpec, wi: Directions, wo: Directions, params: Optional[Params] = None,
             material: Optional[str] = None, white_furnace: bool = False) -> np.ndarray: ...
    @overload
    def eval(self, model: ModelSpec, wi: Directions, wo: Directions, params: Sequence[Params],
             material: Optional[str] = None, white_furnace: bool = False) -> np.ndarray: ...
    def eval(self, model: ModelSpec, wi: Directions, wo: Directions, params: Any = None,
             material: Optional[str] = None, white_furnace: bool = False) -> np.ndarray:
        """f(wi, wo) in 1/sr, RGB, without the cosine; 0 below the horizon.

        ``wi``, ``wo``: unit vectors in lobe's frame, arrays (or lists) of real numbers of
        shape (..., 3) that broadcast together: whatever ``np.asarray(x, dtype=float)`` takes
        (float, int or bool; float32 is kept, the rest read as float64), text and complex
        numbers refused naming the argument. Returns float64 of the broadcast shape (on the
        GPU, the f32 results widened exactly). ``params`` may be a list of dicts: every set is
        evaluated at every pair in one batch on the device, and the result gains a leading axis
        of len(params). ``white_furnace``: every specular Fresnel factor set to 1.

        Refused: a shape that is not (..., 3), values that are not real numbers, NaN or
        infinite components, vectors that are not unit length (ValueError/TypeError naming
        ``wi`` or ``wo``); a model that gives NaN, infinite or negative values
        (InvalidValuesError)."""

    def table(self, model: ModelSpec, grid: str = "full", res: Optional[Sequence[int]] = None,
              params: Optional[Params] = None, material: Optional[str] = None,
              white_furnace: bool = False, max_cells: int = ...) -> Table:
        """The lobe table on a grid of cell-centred angles, in memory: the array the ``.npy`` of
        ``lobe table`` holds, bit for bit, and its axes.

        Axes (``res`` gives the cells per axis in this order; the last axis is RGB):

        - ``grid="full"``: (theta_i, phi_i, theta_o, phi_o); theta_k = (k + 0.5)(pi/2)/N,
          phi_k = (k + 0.5) 2pi/N. Any model.
        - ``grid="isotropic"``: (theta_i, theta_o, delta_phi) with phi_i = 0 and
          delta_phi_k = (k + 0.5) pi/N in [0, pi]. Isotropic parameter sets only.
        - ``grid="halfdiff"`` with three values: Rusinkiewicz's (theta_h, theta_d, phi_d), phi_h
          = 0, phi_d in [0, pi] (isotropic sets); with four: (theta_h, phi_h, theta_d, phi_d),
          phi in [0, 2pi) (any set).

        Returns ``Table(values, axes)``: ``values`` float32 of shape res + (3,); ``axes`` maps
        each axis name to its angles in radians. Refuses tables over ``max_cells`` cells
        (12 bytes a cell) and an anisotropic set on an isotropic grid (ValueError naming the
        grid)."""

    def write_table(self, path: Union[str, os.PathLike[str]], model: ModelSpec, grid: str = "full",
                    res: Optional[Sequence[int]] = None, params: Optional[Params] = None,
                    material: Optional[str] = None, white_furnace: bool = False,
                    allow_invalid: bool = False) -> int:
        """Writes the table set ``PATH.exr``, ``PATH.npy`` and ``PATH.json`` (all or nothing), as
        ``lobe table -o PATH.exr`` does; axes as in :meth:`table`. Returns the count of invalid
        (NaN, infinite, negative) values the table keeps; such a table replaces an existing set
        only with ``allow_invalid``."""

    @overload
    def albedo(self, model: ModelSpec, mu: npt.ArrayLike, params: Optional[Params] = None,
               material: Optional[str] = None, white_furnace: bool = False, phi: float = 0.0,
               method: str = "peak", samples: Optional[int] = None,
               seed: int = 0) -> Albedo: ...
    @overload
    def albedo(self, model: ModelSpec, mu: npt.ArrayLike, params: Sequence[Params],
               material: Optional[str] = None, white_furnace: bool = False, phi: float = 0.0,
               method: str = "peak", samples: Optional[int] = None,
               seed: int = 0) -> Albedo: ...
    def albedo(self, model: ModelSpec, mu: npt.ArrayLike, params: Any = None,
               material: Optional[str] = None, white_furnace: bool = False, phi: float = 0.0,
               method: str = "peak", samples: Optional[int] = None,
               seed: int = 0) -> Albedo:
        """Directional albedo E(wo) = integral f(wi, wo) cos(theta_i) dwi at each mu = cos(theta_o)
        in (0, 1] (any shape), view azimuth ``phi`` (radians; matters for anisotropic sets).
        Returns ``Albedo(albedo, error)``, each of shape mu.shape + (3,): the same numbers as
        ``lobe albedo --mu``. ``params`` may be a list of dicts: the sets are integrated
        together (one batch on the device when they share a model), and the results gain a
        leading axis. ``method``: "peak" (default), "gauss", "midpoint", "qmc", "importance",
        "reference" (the adaptive f64 integrator, on the CPU), or Monte Carlo by "uniform",
        "cosine" or "sampled" draws (the model's own sampler; error 4 standard errors);
        ``samples``: nodes or draws per direction (the method's default when None), for
        "reference" its budget of integrand evaluations for the job. ``seed`` (0 to 2^32 - 1):
        the stream the Monte Carlo methods draw from, as ``lobe albedo --seed``: the same seed
        draws the same directions and gives the same numbers, another seed an independent
        estimate; the other methods draw nothing and ignore it."""

    @overload
    def hemispherical_albedo(self, model: ModelSpec, params: Optional[Params] = None,
                             material: Optional[str] = None, white_furnace: bool = False,
                             phi: float = 0.0, method: str = "peak",
                             samples: Optional[int] = None,
                             seed: int = 0) -> HemisphericalAlbedo: ...
    @overload
    def hemispherical_albedo(self, model: ModelSpec, params: Sequence[Params],
                             material: Optional[str] = None, white_furnace: bool = False,
                             phi: float = 0.0, method: str = "peak",
                             samples: Optional[int] = None,
                             seed: int = 0) -> List[HemisphericalAlbedo]: ...
    def hemispherical_albedo(self, model: ModelSpec, params: Any = None,
                             material: Optional[str] = None, white_furnace: bool = False,
                             phi: float = 0.0, method: str = "peak",
                             samples: Optional[int] = None,
                             seed: int = 0) -> Any:
        """Hemispherical albedo and Kulla-Conty's E_avg (at azimuth ``phi`` for anisotropic
        sets), as ``lobe albedo`` reports them; one result per set for a list of dicts. ``method``,
        ``samples`` and ``seed`` as in :meth:`albedo`."""

    def albedo_lut(self, model: ModelSpec, params: Optional[Params] = None,
                   material: Optional[str] = None, white_furnace: bool = False,
                   param: Union[None, str, Sequence[str]] = None,
                   range: Optional[Tuple[float, float]] = None, res: Tuple[int, int] = (32, 32),
                   mapping: Optional[str] = None, method: str = "peak",
                   samples: Optional[int] = None, phi: float = 0.0,
                   with_avg: bool = True, seed: int = 0) -> AlbedoLut:
        """An albedo look-up table E(mu, p) and E_avg(p), as ``lobe albedo --lut`` computes it,
        in memory. ``param``: the parameter key(s) the rows sweep (the model's own axis when
        None); ``range``: (lo, hi) of p; ``res``: (Nmu, Np); ``mapping``: "linear", "log",
        "square" or "perceptual" (p = (lo + (hi - lo) t)^2). Axes: rows are p (``lut.p``),
        columns are mu_j = (j + 0.5)/Nmu (``lut.mu``). ``method``, ``samples`` and ``seed`` as in
        :meth:`albedo`."""

    def engine_lut(self, kind: str = "dfg", res: Tuple[int, int] = (32, 32),
                   params: Optional[Params] = None, method: str = "peak",
                   samples: Optional[int] = None, seed: int = 0) -> EngineLut:
        """A table a real-time engine loads, as ``lobe albedo --lut --engine KIND`` computes it:
        ``kind`` "dfg" (split-sum: channel 0 multiplies F0, channel 1 F90), "dfg-multiscatter",
        "kulla-conty" (E(mu, alpha) with F = 1, and E_avg) or "eon" (EON's E_hat(mu, r) and its
        average). ``res``: (Nmu, Np); rows are the roughness axis (``p``: alpha or r; ``axis``:
        the perceptual value), columns are mu_j = (j + 0.5)/Nmu. ``method``, ``samples`` and
        ``seed`` as in :meth:`albedo`."""

    def chi2(self, model: ModelSpec, wo: Optional[npt.ArrayLike] = None,
             params: Optional[Params] = None, material: Optional[str] = None,
             samples: int = 1 << 24, seed: int = 0,
             theta_o_deg: Optional[Sequence[float]] = None, phi_o_deg: float = 0.0,
             significance: float = 0.01, white_furnace: bool = False,
             checked_draws: Optional[int] = 1 << 24) -> Dict[str, Any]:
        """The sampling test of the model's own sampler, as ``lobe chi2 --format json``
        reports it: per view direction the observed and expected histograms, the chi-square
        statistic, dof and p-value, the share of draws leaving the hemisphere against
        1 - integral of pdf, the draw-by-draw checks and the verdicts (``"passed"``).

        The view directions are ``wo``, one unit vector of shape (3,) or several (k, 3) above
        the horizon, or else ``theta_o_deg`` (degrees, at azimuth ``phi_o_deg``; by default 0,
        30, 60 and 85). ``samples`` draws per direction (default 2^24), from the random stream
        ``seed``. Drawn and counted on this session's backend (``"backend"`` in the report
        names it): on "gpu" by the counting kernel with the draws checked in f32 there, on
        "cpu" through the f64 reference. Each direction's first ``checked_draws`` draws
        (default 2^24, every draw at the default count; ``None`` for all) also have their
        weight checked against f cos / pdf and their pdf against pdf(wi); the expected counts are the f64 reference pdf's
        integrals over the cells either way. A ``.brdf`` file's own ``sampleL`` and ``pdfL``
        are tested on "gpu" only, the expected counts integrating ``pdfL`` as the device
        evaluates it (``"density"`` in the report names where)."""

    def sample(self, model: ModelSpec, wo: npt.ArrayLike, n: int, params: Optional[Params] = None,
               material: Optional[str] = None, seed: int = 0,
               white_furnace: bool = False) -> Samples:
        """``n`` draws (1 to 2^22) of the model's own sampler for the view direction ``wo`` (a
        unit vector of shape (3,) above the horizon), on this session's backend, as
        ``lobe sample`` draws them: draw i takes its random numbers from the stream ``seed``
        (0 to 2^32 - 1) at index i, so the same seed gives the same draws (bit for bit on one
        backend, within f32 rounding between "gpu" and "cpu"), those of ``lobe sample --seed``
        and of ``lobe chi2 --seed`` at its first view direction."""

    def pdf(self, model: ModelSpec, wi: Directions, wo: Directions, params: Optional[Params] = None,
            material: Optional[str] = None, white_furnace: bool = False) -> np.ndarray:
        """The density of the model's sampler at each (wi, wo) pair over the solid angle of wi,
        in 1/sr: ``wi`` of shape (N, 3), ``wo`` of shape (3,) or (N, 3) (any shapes that
        broadcast; the result has their shape without the last axis). The f64 reference's pdf
        on every backend (a ``.brdf`` file's ``pdfL``, which has no f64 twin, as a "gpu"
        session's kernels evaluate it); 0 where a direction is at or below the horizon; delta
        lobes have no density. At a drawn wi it is the draw's own ``pdf`` (to f32 rounding on
        the GPU)."""

    def fit(self, target: ModelSpec, model: ModelSpec, free: Union[str, Sequence[str]],
            params: Optional[Params] = None, target_params: Optional[Params] = None,
            loss: str = "log", max_bins: int = 65536, starts: int = 4,
            max_iters: int = 400) -> FitResult:
        """Fits the ``free`` parameters of ``model`` (the others as ``params`` set them) to
        ``target``, as ``lobe fit`` does: Nelder-Mead from ``starts`` spread starting points, at
        most ``max_iters`` iterations each, over at most ``max_bins`` bins of the target.
        ``target``: a model spec (with ``target_params``), a MERL ``.binary`` file, or a lobe
        table's ``.npy``. ``loss``: "log" (cosine-weighted log error) or "l2" (relative L2).
        A key both given a value and set free is refused (ValueError naming ``free``)."""

    def light(self, model: ModelSpec, env: Union[str, os.PathLike, npt.ArrayLike], size: int = 256,
              params: Optional[Params] = None, material: Optional[str] = None,
              method: str = "exact") -> np.ndarray:
        """The unit sphere seen from +z under an environment map, as ``lobe light`` computes it:
        a (size, size, 3) float64 array of linear radiance toward the camera, row 0 at +y,
        column 0 at -x, 0 outside the sphere; each pixel the sum of f cos(theta_i) L dOmega over
        every texel of the map above its horizon. ``env``: "sky", "studio", "constant", the path
        of a lat-long OpenEXR or Radiance .hdr file (Mitsuba's envmap layout: +y up,
        u = atan2(x, -z) / 2pi, v = acos(y) / pi), or an (H, W, 3) array of radiance in that
        layout (row 0 at +y; finite and >= 0). ``method``: "exact", or "split_sum" for Karis'
        split sum (the map prefiltered by the model's D about each pixel's mirror direction, times
        the DFG scale and bias of lobe's engine table, plus the Lambertian part; lambert,
        microfacet and cook_torrance only, any other model raises ValueError). A bad
        map raises ValueError naming the first bad texel or what is wrong with the file; a
        missing file, FileNotFoundError."""

    def compare(self, a: ModelSpec, b: ModelSpec, params_a: Optional[Params] = None,
                params_b: Optional[Params] = None, grid: Optional[str] = None,
                res: Optional[Sequence[int]] = None, mu: npt.ArrayLike = (0.1, 0.5, 1.0),
                method: str = "peak", samples: Optional[int] = None, albedo: bool = True,
                white_furnace: bool = False) -> Dict[str, Any]:
        """Compares model ``b`` against the reference ``a`` on the same bins, as ``lobe compare``
        does, and returns the metrics it prints (its JSON report): relative L2 |B - A| / |A| per
        channel, the largest relative difference |B - A| / max(|A|, |B|, 1e-4) and where it
        is, bins weighted by solid angle, and the directional albedo differences E_A - E_B at
        each ``mu`` (left out with ``albedo=False``). Bins: MERL's own when a side is a MERL
        file, else ``grid`` ("full", "isotropic" or "halfdiff", default isotropic, or full when
        a side is anisotropic) at ``res`` (default 16,32,16,32 / 45,45,90 / 90,90,180)."""
