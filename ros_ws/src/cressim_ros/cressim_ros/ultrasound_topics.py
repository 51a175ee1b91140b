"""The twin's ultrasound topic: each env's B-mode image as sensor_msgs/Image `mono8` on
`/ultrasound/image_raw` (`/env{i}/ultrasound/image_raw` in batched mode), frame
`ultrasound_probe` (posed on /tf_static: +z along the beam, x across the scanlines).

The engine's image is log-compressed brightness in [0, 1] (docs/ultrasound.md); mono8 is the
engine's `image_u8`, round(255 x brightness), made on the GPU. All envs' images come to the host
in one copy per frame.
"""
from __future__ import annotations

from array import array

import numpy as np
from sensor_msgs.msg import CompressedImage, Image

from .image_compression import compress_image
from .topics import IMAGE_QOS


def ultrasound_topic(env: int, num_envs: int) -> str:
    return "/ultrasound/image_raw" if num_envs == 1 else f"/env{env}/ultrasound/image_raw"


def ultrasound_frame(env: int, num_envs: int, frame: str) -> str:
    return frame if num_envs == 1 else f"env{env}/{frame}"


class UltrasoundTopics:
    def __init__(self, node, engine, spec, num_envs: int):
        self.engine, self.spec, self.num_envs = engine, spec, num_envs
        probes = engine.ultrasound_probes
        self.layers = [int(probes["layer"][k]) for k in np.argsort(probes["env"])]  # env -> layer
        self.pubs = [node.create_publisher(Image, ultrasound_topic(env, num_envs), IMAGE_QOS) for env in range(num_envs)]
        # image_transport's `compressed` (PNG: speckle is what JPEG loses), only while subscribed
        self.compressed_pubs = [node.create_publisher(CompressedImage, f"{ultrasound_topic(env, num_envs)}/compressed",
                                                      IMAGE_QOS) for env in range(num_envs)]
        self.frames = [ultrasound_frame(env, num_envs, spec.frame) for env in range(num_envs)]

    def read(self):
        """Every env's B-mode image as mono8, after the frame that computed them (one copy)."""
        return self.engine.buffer("ultrasound0.image_u8").read()  # quantised on the GPU: a quarter of the copy

    def publish(self, images, stamp, record=None):
        height, width = images.shape[1:]
        for env, pub in enumerate(self.pubs):
            m = Image()
            m.header.stamp, m.header.frame_id = stamp, self.frames[env]
            m.height, m.width, m.encoding, m.is_bigendian, m.step = height, width, "mono8", 0, width
            m.data = array("B", images[self.layers[env]].tobytes())
            pub.publish(m)
            if self.compressed_pubs[env].get_subscription_count():
                self.compressed_pubs[env].publish(compress_image(images[self.layers[env]], "png", header=m.header))
            if record is not None:
                record(ultrasound_topic(env, self.num_envs), m)


__all__ = ["UltrasoundTopics", "ultrasound_frame", "ultrasound_topic"]
