"""The twin's ultrasound probe, in this process (ticked by hand): the anechoic cyst under the probe
is dark in the published image, the probe is on /tf_static, images are recorded, and the group
can only be switched on at start."""
import numpy as np
import pytest
import yaml

pytestmark = pytest.mark.ros

SENSORS = ["joints", "tf", "ultrasound"]


def _image(node, ticks=12):
    sensor = node.sensors.sensors["ultrasound"]
    before = sensor.rendered
    for _ in range(ticks):
        node._tick()
        if sensor.rendered > before:
            return node.arms.bodies.engine.buffer("ultrasound0.image").read()[0]
    raise AssertionError("no ultrasound frame")


def test_the_cyst_under_the_probe_is_dark(make_node):
    node = make_node(sensors=SENSORS, ultrasound_rate=50.0)
    spec = node.arms.bodies.scenery.ultrasound
    img = _image(node)
    h, w = img.shape
    # the cyst sits under the probe's centre line at half the tissue's depth (1 cm of a 2 cm image)
    cyst_px = spec.cyst_radius / spec.depth * h
    r, c = np.mgrid[0:h, 0:w]
    d = np.hypot(r + 0.5 - h * 0.01 / spec.depth, c + 0.5 - w / 2)
    inside, outside = img[d < 0.5 * cyst_px], img[(d > 1.5 * cyst_px) & (r < h // 2 + 4)]
    # 20 dB darker is 20 / 50 of the display's dynamic range
    assert outside.mean() - inside.mean() > 20 / 50, (inside.mean(), outside.mean())
    frames = {t.child_frame_id for t in node.static_tf.transforms}
    assert "ultrasound_probe" in frames


def test_ultrasound_is_recorded(make_node, tmp_path):
    bag = tmp_path / "bag"
    node = make_node(sensors=SENSORS, ultrasound_rate=50.0, record=str(bag))
    for _ in range(10):
        node._tick()
    node.close()
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    counts = {t["topic_metadata"]["name"]: t["message_count"] for t in meta["topics_with_message_count"]}
    assert counts["/ultrasound/image_raw"] == 5  # 50 Hz of 100 Hz ticks


def test_ultrasound_can_only_start_with_the_node(make_node):
    from rclpy.parameter import Parameter

    node = make_node(sensors=["joints"])
    result = node.set_parameters([Parameter("sensors", value=["joints", "ultrasound"])])[0]
    assert not result.successful and "restart" in result.reason
    assert node.ultrasound is None
