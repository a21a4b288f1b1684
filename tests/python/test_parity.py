"""GPU (f32 kernels) against the f64 CPU reference, within lobe's parity tolerance."""

import numpy as np
import pytest

import lobe

CASES = [
    ("cook_torrance", {"material": "gold"}),
    ("microfacet", {"params": {"alpha": 0.2, "distribution": "beckmann"}}),
    ("oren_nayar", {}),
    ("ashikhmin_shirley", {"params": {"nu": 10, "nv": 1000}}),
]


def upper_hemisphere(rng, n):
    v = rng.normal(size=(n, 3))
    v[:, 2] = np.abs(v[:, 2])
    return v / np.linalg.norm(v, axis=1, keepdims=True)


@pytest.mark.parametrize("model,kwargs", CASES)
def test_gpu_matches_the_cpu_reference_within_the_parity_tolerance(gpu, cpu, model, kwargs):
    rng = np.random.default_rng(7)
    wi, wo = upper_hemisphere(rng, 2000), upper_hemisphere(rng, 2000)
    g = gpu.eval(model, wi, wo, **kwargs)
    c = cpu.eval(model, wi, wo, **kwargs)
    allowed = lobe.parity_tolerance(model, wi, wo, **kwargs)
    worst = np.argmax(np.abs(g - c) / allowed) // 3
    assert (np.abs(g - c) <= allowed).all(), (model, wi[worst], wo[worst], g[worst], c[worst], allowed[worst])


def test_gpu_albedo_matches_the_cpu_within_the_error_estimates(gpu, cpu):
    mu = np.array([0.1, 0.5, 1.0])
    g = gpu.albedo("cook_torrance", mu=mu, material="gold")
    c = cpu.albedo("cook_torrance", mu=mu, material="gold")
    # Each estimate bounds its own integration error; f32 sums on the GPU add at most a few
    # f32 ulps of E (E < 1), so 1e-6 absolute covers the rest.
    assert (np.abs(g.albedo - c.albedo) <= g.error + c.error + 1e-6).all()
