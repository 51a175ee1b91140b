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
