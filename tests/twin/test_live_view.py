"""The twin's live view: a client speaking the Foxglove WebSocket protocol (the `websockets`
library, the protocol written out here) connects to the twin node's server, sees the channels it
advertises, subscribes and receives the twin's joint states, URDF and camera images. The viewer
joins after the URDF was published: Foxglove keeps nothing for late joiners, the live view must."""
import contextlib
import json
import socket
import struct
import time

import pytest

pytest.importorskip("foxglove")
pytestmark = pytest.mark.ros

from twin_fixtures import spinning  # noqa: E402


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


@contextlib.contextmanager
def _viewer(port: int):
    from websockets.sync.client import connect

    with connect(f"ws://127.0.0.1:{port}", subprotocols=["foxglove.sdk.v1", "foxglove.websocket.v1"],
                 open_timeout=60, proxy=None) as ws:  # loopback: never through a proxy from the environment
        info = json.loads(ws.recv(timeout=60))
        assert info["op"] == "serverInfo" and info["name"] == "cressim twin"
        yield ws


def _channels(ws, count: int) -> dict:
    """topic -> channel of the server's advertisements, until `count` channels are known."""
    channels = {}
    while len(channels) < count:  # each advertise names some channels
        msg = json.loads(ws.recv(timeout=60))
        if msg["op"] == "advertise":
            channels.update({c["topic"]: c for c in msg["channels"]})
    return channels


def _first_messages(ws, channels: dict, wanted: dict) -> dict:
    """Subscribes to `wanted` (id -> topic) and returns each one's first payload by id."""
    ws.send(json.dumps({"op": "subscribe", "subscriptions": [
        {"id": sid, "channelId": channels[topic]["id"]} for sid, topic in wanted.items()]}))
    got = {}
    for _ in range(100_000):  # message data: opcode 1, subscription id, log time, payload
        if len(got) == len(wanted):
            break
        frame = ws.recv(timeout=120)
        if isinstance(frame, bytes) and frame[0] == 1:
            sid = struct.unpack_from("<I", frame, 1)[0]
            got.setdefault(sid, frame[13:])
    return got


def test_a_foxglove_client_sees_the_twin(make_node):
    port = _free_port()
    node = make_node(live_view=port, sensors=["joints", "tf", "color", "depth"], camera_rate=50.0)
    with spinning(node, "live_view_peer"):
        while set(node.live_view.latch.last) != {"/robot_description", "/tf_static"}:  # the late joiner's case
            time.sleep(0.05)
        with _viewer(port) as ws:
            channels = _channels(ws, 7)
            assert {"/camera/color/image_raw", "/camera/depth/image_raw", "/camera/color/camera_info", "/tf",
                    "/tf_static", "/joint_states", "/robot_description"} == set(channels)
            assert channels["/joint_states"]["schemaName"] == "foxglove.JointStates"
            assert channels["/camera/color/image_raw"]["schemaName"] == "foxglove.RawImage"
            wanted = {1: "/joint_states", 2: "/robot_description", 3: "/camera/color/image_raw"}
            got = _first_messages(ws, channels, wanted)
        assert set(got) == set(wanted), f"received only {sorted(wanted[i] for i in got)}"
        assert b"pitch_bottom" in got[1]  # the URDF joints (robot_state_publisher's) in the JointStates message
        assert json.loads(got[2])["data"].lstrip().startswith("<")  # the URDF, as robot_state_publisher's
        assert b"rgb8" in got[3] and len(got[3]) > 64 * 48 * 3  # the whole 64 x 48 image


def test_a_taken_port_is_a_clear_error(make_node):
    from cressim.twin import ConfigError

    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        with pytest.raises(ConfigError, match=f"live_view: port {taken.getsockname()[1]}"):
            make_node(live_view=taken.getsockname()[1], sensors=["joints"])


def test_the_live_view_shows_every_camera_and_arm_of_a_cart(make_node):
    """A patient cart's live view: both eyes' images and calibrations, and each arm's joint states
    and URDF (PSM1, PSM2, the ECM), as the single twin's are shown."""
    port = _free_port()
    node = make_node(scene="patient_cart.yaml", live_view=port, sensors=["joints", "tf", "color", "depth"],
                     camera_rate=50.0)
    arms = ["/PSM1", "/PSM2", "/ECM"]
    latched = {f"{a}/robot_description" for a in arms} | {"/tf_static"}
    with spinning(node, "live_view_peer"):
        while set(node.live_view.latch.last) != latched:
            time.sleep(0.05)
        with _viewer(port) as ws:
            channels = _channels(ws, 6 + 2 + 2 * len(arms))
            eyes = {f"/camera/{eye}/{product}" for eye in ("left", "right") for product in
                    ("color/image_raw", "depth/image_raw", "color/camera_info")}
            assert set(channels) == eyes | {"/tf", "/tf_static"} | {f"{a}/joint_states" for a in arms} | \
                {f"{a}/robot_description" for a in arms}
            wanted = {1: "/camera/left/color/image_raw", 2: "/camera/right/color/image_raw", 3: "/ECM/joint_states",
                      4: "/PSM2/robot_description"}
            got = _first_messages(ws, channels, wanted)
    assert set(got) == set(wanted), f"received only {sorted(wanted[i] for i in got)}"
    assert all(b"rgb8" in got[k] and len(got[k]) > 64 * 48 * 3 for k in (1, 2))  # each eye's whole image
    assert b"ECM_" in got[3] or b"yaw" in got[3]  # the ECM's URDF joints
    assert "PSM2_" in json.loads(got[4])["data"]  # PSM2's own URDF (its links under its name)
