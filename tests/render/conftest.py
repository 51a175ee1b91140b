"""Render tests run on both rasterizers (CRESSIM_RASTER: graphics pipelines, compute passes)
where they ask for the `raster` fixture."""
import pytest


@pytest.fixture(params=["graphics", "compute"])
def raster(request, monkeypatch):
    monkeypatch.setenv("CRESSIM_RASTER", request.param)
    return request.param
