"""Shared fixtures: the repository's data, a small self-similar surface, and models encoded once
per session (encoding the bunny takes about half a second)."""

import os
import pathlib
import shutil

import numpy as np
import pytest

import sspc

SOURCE_DIR = pathlib.Path(os.environ.get("SSPC_SOURCE_DIR", pathlib.Path(__file__).resolve().parents[2]))


@pytest.fixture(scope="session")
def bunny_path():
    return SOURCE_DIR / "data" / "bunny.ply"


@pytest.fixture(scope="session")
def bunny(bunny_path):
    return sspc.read(bunny_path)


@pytest.fixture(scope="session")
def bumps():
    """4,000 points on a plane of identical bumps, with normals: encodes in a fraction of a second."""
    return sspc.synthetic.bumps(4000, 1.0, 4, 0.05, seed=3)


@pytest.fixture(scope="session")
def bunny_model_path(bunny, tmp_path_factory):
    path = tmp_path_factory.mktemp("model") / "bunny.sspc"
    sspc.encode(bunny, path, level=5)
    return path


@pytest.fixture(scope="session")
def bunny_model(bunny_model_path):
    return sspc.CompressedModel.open(bunny_model_path)


@pytest.fixture(scope="session")
def cli():
    """The sspc command-line tool of the same build, or skip."""
    path = os.environ.get("SSPC_CLI") or shutil.which("sspc")
    if not path or not os.path.exists(path):
        pytest.skip("the sspc command-line tool is not built (SSPC_BUILD_APPS=OFF)")
    return path


def rows(cloud):
    """The cloud's positions as a set of rows, for subset tests."""
    return {tuple(p) for p in np.asarray(cloud.positions).tolist()}
