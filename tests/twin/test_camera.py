"""The twin's camera, in this process (ticked by hand): metric depth against the scene's geometry,
intrinsics against the field of view, segmentation labels that follow the arm, camera topics in
the recording, and the camera size fixed while running."""
import math

import numpy as np
import pytest
import yaml

pytestmark = pytest.mark.ros

W, H = 96, 72


def _render(node, ticks=5):
    camera = node.sensors.sensors["camera"]
    before = camera.rendered
    for _ in range(ticks):
        node._tick()
        if camera.rendered > before:
            return node.camera.host_images(("color", "depth", "segmentation"))
    raise AssertionError("no camera frame rendered")


def test_depth_at_the_image_centre_is_the_distance_to_the_tissue(make_node):
    from cressim.twin.scenery import TISSUE_HALF

    node = make_node(camera_width=W, camera_height=H)
    spec = node.arms.bodies.scenery.camera
    images = _render(node)
    # the optical axis from the camera towards look_at meets the tissue's top face
    p, target = np.array(spec.position), np.array(spec.look_at)
    axis = (target - p) / np.linalg.norm(target - p)
    top = spec.table_z + 2 * TISSUE_HALF[2]
    hit = p + axis * (top - p[2]) / axis[2]
    assert abs(hit[0]) < TISSUE_HALF[0] and abs(hit[1]) < TISSUE_HALF[1]  # the scene is as this test assumes
    expected = float(np.linalg.norm(hit - p))  # along the optical axis: the hit is on it
    depth = images["depth"][0]
    centre = depth[H // 2 - 1: H // 2 + 1, W // 2 - 1: W // 2 + 1]  # the four pixels around the axis
    assert abs(float(centre.mean()) - expected) < 1e-3, (centre, expected)
    ids = {name: k for k, name in node.arms.bodies.scenery.labels.items()}
    assert images["segmentation"][0][H // 2, W // 2] == ids["tissue"]
    assert np.isnan(depth).any() and np.nanmin(depth) > 0  # sky: no return (REP 118), NaN


def test_camera_info_matches_the_field_of_view(make_node):
    node = make_node(camera_width=W, camera_height=H)
    info = node.camera.infos[0]
    fy = info.k[4]
    assert math.isclose(2 * math.degrees(math.atan(0.5 * H / fy)), node.scene.camera_fov_y, rel_tol=1e-9)
    assert (info.k[2], info.k[5]) == (W / 2 - 0.5, H / 2 - 0.5)  # ROS: pixel centres at integers
    assert (info.width, info.height, info.header.frame_id) == (W, H, "camera_color_optical_frame")


def test_segmentation_follows_the_arm(make_node):
    node = make_node(camera_width=W, camera_height=H)
    shaft = {v: k for k, v in node.arms.bodies.scenery.labels.items()}["PSM1_shaft_link"]
    before = _render(node)["segmentation"][0] == shaft
    assert before.sum() > 10, "the shaft is in view"
    from cressim.twin import JointCommand

    arms = node.arms
    arms.state_command(0, "enable")
    arms.state_command(0, "home")
    while arms.states[0].is_busy:
        node._tick()
    assert arms.servo_jp(0, JointCommand(position=[0.4, 0.0, 0.12, 0.0, 0.0, 0.0])) == []  # yaw the arm
    for _ in range(20):
        node._tick()
    after = _render(node)["segmentation"][0] == shaft
    cols_before, cols_after = np.nonzero(before)[1].mean(), np.nonzero(after)[1].mean()
    assert abs(cols_after - cols_before) > 3, (cols_before, cols_after)


def test_camera_topics_are_recorded(make_node, tmp_path):
    bag = tmp_path / "bag"
    node = make_node(camera_width=W, camera_height=H, record=str(bag))
    for _ in range(10):
        node._tick()
    node.close()
    meta = yaml.safe_load((bag / "metadata.yaml").read_text())["rosbag2_bagfile_information"]
    counts = {t["topic_metadata"]["name"]: t["message_count"] for t in meta["topics_with_message_count"]}
    for product in ("color", "depth", "segmentation"):
        assert counts[f"/camera/{product}/image_raw"] == counts[f"/camera/{product}/camera_info"] >= 3
    assert counts["/tf_static"] == 1 and counts["/tf"] >= 4
    assert counts["/camera/segmentation/labels"] == 1  # latched before the recording opened


def test_camera_size_cannot_change_while_running(make_node):
    from rclpy.parameter import Parameter

    node = make_node(camera_width=W, camera_height=H)
    result = node.set_parameters([Parameter("camera_width", value=128)])[0]
    assert not result.successful and "restart" in result.reason
    result = node.set_parameters([Parameter("camera_rate", value=10.0)])[0]
    assert result.successful


def test_compressed_topics_decode_to_the_raw_images(make_node):
    """image_transport's `compressed` and `compressedDepth` beside image_raw, encoded only while
    subscribed; decoded here as the plugins' subscribers do (Pillow, the header for depth)."""
    import io
    import struct

    import rclpy
    from PIL import Image as PILImage
    from rclpy.executors import SingleThreadedExecutor
    from sensor_msgs.msg import CompressedImage

    node = make_node(camera_width=W, camera_height=H, camera_rate=100.0)
    client = rclpy.create_node("compressed_client", context=node.context)
    got = {}
    for topic in ("/camera/color/image_raw/compressed", "/camera/depth/image_raw/compressedDepth",
                  "/camera/segmentation/image_raw/compressed"):
        client.create_subscription(CompressedImage, topic, lambda m, t=topic: got.setdefault(t, m), 10)
    executor = SingleThreadedExecutor(context=node.context)
    executor.add_node(client)
    try:
        for _ in range(400):  # the arm stands still: every frame is the same image
            if len(got) == 3:
                break
            node._tick()
            executor.spin_once(timeout_sec=0.05)
        assert len(got) == 3, sorted(got)
        raw = node.camera.host_images(("color", "depth", "segmentation"))
        color = got["/camera/color/image_raw/compressed"]
        assert color.format == "rgb8; jpeg compressed bgr8"
        decoded = np.asarray(PILImage.open(io.BytesIO(bytes(color.data))))
        assert decoded.shape == (H, W, 3) and np.abs(decoded.astype(int) - raw["color"][0]).mean() < 4
        seg = got["/camera/segmentation/image_raw/compressed"]
        assert np.array_equal(np.asarray(PILImage.open(io.BytesIO(bytes(seg.data)))), raw["segmentation"][0])
        depth = got["/camera/depth/image_raw/compressedDepth"]
        assert depth.format == "32FC1; compressedDepth png"
        kind, a, b = struct.unpack("<iff", bytes(depth.data[:12]))
        n = np.asarray(PILImage.open(io.BytesIO(bytes(depth.data[12:])))).astype(np.float64)
        d = np.where(n > 0, a / np.maximum(n - b, 1e-9), np.nan)
        truth = raw["depth"][0]
        assert kind == 0 and np.array_equal(np.isnan(d), np.isnan(truth))
        assert np.nanmax(np.abs(d - truth)) < 0.01  # one inverse-depth step at 0.3 m is under 0.2 mm
    finally:
        executor.shutdown()
        client.destroy_node()
