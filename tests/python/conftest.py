"""Fixtures of the Python suite: the installed package, the `lobe` binary it is compared with,
and one session per backend (opening a device and building pipelines once per run)."""

import os
import sys

import pytest

import lobe


def pytest_configure(config):
    # The suite tests the package as installed, not the source tree beside it.
    here = os.path.realpath(lobe.__file__)
    if not here.startswith(os.path.realpath(sys.prefix)):
        raise pytest.UsageError(f"lobe was imported from {here}, not from the environment {sys.prefix}")


@pytest.fixture(scope="session")
def lobe_bin():
    path = os.environ.get("LOBE_BIN")
    if not path or not os.path.isfile(path):
        pytest.fail("LOBE_BIN must name the lobe binary (tests/python.rs sets it)")
    return path


@pytest.fixture(scope="session")
def gpu():
    return lobe.Session(backend="gpu")


@pytest.fixture(scope="session")
def cpu():
    return lobe.Session(backend="cpu")


@pytest.fixture(params=["gpu", "cpu"])
def session(request, gpu, cpu):
    return gpu if request.param == "gpu" else cpu
