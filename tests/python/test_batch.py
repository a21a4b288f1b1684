"""Many parameter sets in one call give the values of one call per set."""

import numpy as np
import pytest

SETS = [{"alpha": a, "specular": (1.0, 0.8, 0.3)} for a in (0.05, 0.2, 0.5, 0.9)]


@pytest.mark.parametrize("backend", ["gpu", "cpu"])
def test_eval_of_a_list_of_sets_equals_one_call_per_set(gpu, cpu, backend):
    s = gpu if backend == "gpu" else cpu
    rng = np.random.default_rng(3)
    wi = rng.normal(size=(7, 5, 3))
    wo = rng.normal(size=(7, 5, 3))
    wi /= np.linalg.norm(wi, axis=-1, keepdims=True)
    wo /= np.linalg.norm(wo, axis=-1, keepdims=True)
    many = s.eval("microfacet", wi, wo, params=SETS)
    assert many.shape == (len(SETS), 7, 5, 3)
    for k, p in enumerate(SETS):
        assert many[k].tobytes() == s.eval("microfacet", wi, wo, params=p).tobytes()


def test_albedo_of_a_list_of_sets_equals_one_call_per_set(gpu):
    mu = np.array([[0.2, 0.6], [0.9, 1.0]])
    many = gpu.albedo("microfacet", mu=mu, params=SETS)
    assert many.albedo.shape == many.error.shape == (len(SETS), 2, 2, 3)
    for k, p in enumerate(SETS):
        one = gpu.albedo("microfacet", mu=mu, params=p)
        assert many.albedo[k].tobytes() == one.albedo.tobytes()
    hemis = gpu.hemispherical_albedo("microfacet", params=SETS)
    for h, p in zip(hemis, SETS):
        assert h.albedo.tolist() == gpu.hemispherical_albedo("microfacet", params=p).albedo.tolist()
