"""A live view of the twin for people: a Foxglove WebSocket server (foxglove-sdk) that streams what
the twin publishes, for Foxglove (app.foxglove.dev or the desktop app: "Open connection",
ws://HOST:PORT). docs/twin.md, "Live view", shows how.

It listens to the twin's own topics (env 0's: one env is what a person watches; every camera and
arm of it, a patient cart's two eyes and each arm) on a node of its own in the twin's process and
hands them on in Foxglove's schemas, so that the 3D, Image and Plot panels need no ROS on the
viewer's side. For each camera namespace CAM (/camera; a cart's /camera/left, /camera/right) and
each arm's topic prefix ARM ("" for the single twin; a cart's /PSM1, /PSM2, /ECM):

    CAM/color/image_raw, CAM/depth/image_raw   foxglove.RawImage (rgb8, 32FC1)
    CAM/color/camera_info                      foxglove.CameraCalibration
    /tf, /tf_static                            foxglove.FrameTransforms
    ARM/joint_states                           foxglove.JointStates
    ARM/robot_description                      the URDF (JSON {"data": ...}, std_msgs/String's shape)

Foxglove keeps no message for late joiners, so the latched topics (the URDF, /tf_static) are kept
here and logged again whenever a viewer subscribes to them.
"""
from __future__ import annotations

import threading

import foxglove
from foxglove.channels import CameraCalibrationChannel, FrameTransformsChannel, JointStatesChannel, RawImageChannel
from foxglove.websocket import ServerListener
from foxglove.messages import (CameraCalibration, FrameTransform, FrameTransforms, JointState, JointStates,
                               Quaternion, RawImage, Timestamp, Vector3)
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image
from sensor_msgs.msg import JointState as RosJointState
from std_msgs.msg import String
from tf2_msgs.msg import TFMessage

from .topics import LATCHED_QOS

STREAM_QOS = QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT, durability=DurabilityPolicy.VOLATILE)
STRING_SCHEMA = {"type": "object", "properties": {"data": {"type": "string"}}}


def _time(stamp) -> Timestamp:
    return Timestamp(sec=stamp.sec, nsec=stamp.nanosec)


def _transforms(msg: TFMessage) -> FrameTransforms:
    return FrameTransforms(transforms=[
        FrameTransform(timestamp=_time(t.header.stamp), parent_frame_id=t.header.frame_id, child_frame_id=t.child_frame_id,
                       translation=Vector3(x=t.transform.translation.x, y=t.transform.translation.y,
                                           z=t.transform.translation.z),
                       rotation=Quaternion(x=t.transform.rotation.x, y=t.transform.rotation.y,
                                           z=t.transform.rotation.z, w=t.transform.rotation.w))
        for t in msg.transforms])


class _Latch(ServerListener):
    """The last message of each latched channel, logged again when a viewer subscribes to it. The
    log happens on a thread of its own: the server calls on_subscribe from its own runtime."""

    def __init__(self):
        self.channels = {}  # topic: channel
        self.last = {}  # topic: message
        self.lock = threading.Lock()

    def log(self, topic: str, msg):
        with self.lock:
            self.last[topic] = msg
            self.channels[topic].log(msg)

    def on_subscribe(self, client, channel):
        if channel.topic in self.channels:
            threading.Thread(target=self._again, args=(channel.topic,), daemon=True).start()

    def _again(self, topic: str):
        with self.lock:
            if topic in self.last:
                self.channels[topic].log(self.last[topic])


class LiveView:
    def __init__(self, node, port: int, *, cameras=("/camera",), robots=("",), host: str = "127.0.0.1"):
        self.context = foxglove.Context()
        self.latch = _Latch()
        self.server = foxglove.start_server(name="cressim twin", host=host, port=port, context=self.context,
                                            server_listener=self.latch)
        self.port = self.server.port
        c = self.context
        self.images = {f"{cam}/{product}/image_raw": RawImageChannel(f"{cam}/{product}/image_raw", context=c)
                       for cam in cameras for product in ("color", "depth")}
        self.calibrations = {f"{cam}/color/camera_info": CameraCalibrationChannel(f"{cam}/color/camera_info", context=c)
                             for cam in cameras}
        self.tf = FrameTransformsChannel("/tf", context=c)
        self.tf_static = FrameTransformsChannel("/tf_static", context=c)
        self.joints = {f"{arm}/joint_states": JointStatesChannel(f"{arm}/joint_states", context=c) for arm in robots}
        self.latch.channels["/tf_static"] = self.tf_static
        for arm in robots:
            topic = f"{arm}/robot_description"
            self.latch.channels[topic] = foxglove.Channel(topic, schema=STRING_SCHEMA, context=c)
        sub = node.create_subscription
        self.subscriptions = [sub(Image, topic, lambda m, t=topic: self._image(t, m), STREAM_QOS)
                              for topic in self.images]
        self.subscriptions += [sub(CameraInfo, topic, lambda m, t=topic: self._camera_info(t, m), STREAM_QOS)
                               for topic in self.calibrations]
        self.subscriptions += [sub(RosJointState, topic, lambda m, t=topic: self._joint_states(t, m), STREAM_QOS)
                               for topic in self.joints]
        self.subscriptions += [sub(String, f"{arm}/robot_description",
                                   lambda m, t=f"{arm}/robot_description": self.latch.log(t, {"data": m.data}),
                                   LATCHED_QOS) for arm in robots]
        self.subscriptions += [
            sub(TFMessage, "/tf", lambda m: self.tf.log(_transforms(m)), STREAM_QOS),
            sub(TFMessage, "/tf_static", lambda m: self.latch.log("/tf_static", _transforms(m)), LATCHED_QOS)]

    def _image(self, topic: str, m: Image):
        self.images[topic].log(RawImage(timestamp=_time(m.header.stamp), frame_id=m.header.frame_id, width=m.width,
                                        height=m.height, encoding=m.encoding, step=m.step, data=bytes(m.data)))

    def _camera_info(self, topic: str, m: CameraInfo):
        self.calibrations[topic].log(CameraCalibration(timestamp=_time(m.header.stamp), frame_id=m.header.frame_id,
                                               width=m.width, height=m.height, distortion_model=m.distortion_model,
                                               D=list(m.d), K=list(m.k), R=list(m.r), P=list(m.p)))

    def _joint_states(self, topic: str, m: RosJointState):
        def at(values, i):
            return float(values[i]) if i < len(values) else None

        self.joints[topic].log(JointStates(timestamp=_time(m.header.stamp), joints=[
            JointState(name=name, position=at(m.position, i), velocity=at(m.velocity, i), effort=at(m.effort, i))
            for i, name in enumerate(m.name)]))

    def close(self):
        self.server.stop()

