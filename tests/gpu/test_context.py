import os
import subprocess
import sys

import pytest

import cressim


def test_validation_layer_is_loaded(make_engine, small_world):
    engine = make_engine(small_world)
    assert engine.validation_enabled
    assert engine.device["validation"]


def test_device_is_chosen_and_described(make_engine, small_world):
    devices = cressim.list_devices()
    assert devices, "no Vulkan device"
    info = make_engine(small_world).device
    assert info["name"] in [d["name"] for d in devices]
    assert info["vulkan"].startswith("1.")
    assert int(info["vulkan"].split(".")[1]) >= 3
    assert info["subgroup_size"] > 0


def test_device_override_by_name_and_index(make_engine, small_world):
    first = cressim.list_devices()[0]
    by_index = make_engine(small_world, device="0").device
    assert by_index["name"] == first["name"]
    substring = first["name"].split()[0].lower()
    assert make_engine(small_world, device=substring).device["name"] == first["name"]


def test_unknown_device_lists_the_devices(small_world):
    with pytest.raises(cressim.VulkanError, match="matches no device; devices are"):
        cressim.Engine(small_world, device="no-such-gpu-xyz")


def test_pipeline_statistics_are_logged_or_said_to_be_missing():
    """CRESSIM_PIPELINE_STATISTICS=1: a line per compute pipeline with what the driver reports
    (the register count on NVIDIA), or one line saying that the device reports none (lavapipe)."""
    code = ("import cressim\n"
            "w = cressim.World(cressim.SceneLayout(1))\n"
            "c = w.create_entity(env=0, name='cube')\n"
            "c.add(cressim.Transform(position=(0, 0, 0.2)))\n"
            "c.add(cressim.SoftBody(cressim.TetMesh.box((0.1, 0.1, 0.1), (2, 2, 2))))\n"
            "e = cressim.Engine(w)\n"
            "e.prepare()\n"
            "e.upload_world()\n")
    env = dict(os.environ, CRESSIM_PIPELINE_STATISTICS="1")
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    lines = [line for line in out.stderr.splitlines() if line.startswith("cressim: pipeline ")]
    if "reports no pipeline statistics (VK_KHR_pipeline_executable_properties)" in out.stderr:
        assert not lines
    else:
        assert lines and all("=" in line for line in lines), out.stderr
    quiet = subprocess.run([sys.executable, "-c", code], env=dict(os.environ, CRESSIM_PIPELINE_STATISTICS="0"),
                           capture_output=True, text=True, timeout=600)
    assert "pipeline statistics" not in quiet.stderr and "cressim: pipeline " not in quiet.stderr
