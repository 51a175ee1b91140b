"""The twin's camera topics: sensor_msgs/Image + CameraInfo per env from the engine's layered
camera outputs, as a ROS camera driver publishes them.

    /camera/color/image_raw            rgb8
    /camera/depth/image_raw            32FC1, metres along the optical axis, NaN where nothing was hit (REP 118)
    /camera/segmentation/image_raw     16UC1, 0 background, ids of `segmentation/labels`
    /camera/<product>/camera_info      the same intrinsics for all three (registered: one camera)
    /camera/segmentation/labels        std_msgs/String, JSON {id: name}, transient local

In batched mode env i's are under /env{i}/camera. Frame: `camera_color_optical_frame` (with the
env prefix in batched mode), z forward, x right, y down. CameraInfo follows ROS's pixel
convention (the centre of pixel (0, 0) is at (0, 0)), so its cx, cy are the engine's minus 0.5.

All envs' images come to the host in one readback per rendered frame (every product), and each
is converted straight into its message's data (reused from frame to frame: rclpy copies it when
publishing); publishing loops over envs (ROS needs a message per env and topic).
"""
from __future__ import annotations

import json
from array import array
from typing import NamedTuple

import numpy as np
from sensor_msgs.msg import CameraInfo, CompressedImage, Image
from std_msgs.msg import String

from cressim.twin.camera_images import DTYPES, PRODUCTS, CameraImages

from .image_compression import compress_depth, compress_image, depth_quantization_for
from .topics import IMAGE_QOS, LATCHED_QOS
ENCODINGS = {"color": ("rgb8", 3), "depth": ("32FC1", 4), "segmentation": ("16UC1", 2)}
# image_transport's transports beside image_raw: `compressed` (JPEG colour, 16-bit PNG labels)
# and `compressedDepth`; encoded only while someone subscribes, as image_transport does
COMPRESSED = {"color": "compressed", "depth": "compressedDepth", "segmentation": "compressed"}


def camera_namespace(env: int, num_envs: int) -> str:
    return "/camera" if num_envs == 1 else f"/env{env}/camera"


def camera_frame(env: int, num_envs: int) -> str:
    return "camera_color_optical_frame" if num_envs == 1 else f"env{env}/camera_color_optical_frame"


class CameraView(NamedTuple):
    """One camera as ROS sees it: its namespace, optical frame, CameraInfo's P[3] (-fx B for a
    stereo pair's right camera, 0 for a single or left one) and the env it sees."""
    namespace: str
    frame: str
    p_tx: float = 0.0
    env: int = 0


def env_views(num_envs: int) -> list[CameraView]:
    """The twin's one camera per env."""
    return [CameraView(camera_namespace(env, num_envs), camera_frame(env, num_envs), env=env) for env in range(num_envs)]


class CameraTopics:
    """Publishers of every camera's products (`views`, in the engine's camera order: env, then
    authoring order; default one per env), fed from the engine after a rendered frame."""

    def __init__(self, node, engine, spec, labels: dict, num_envs: int, views: list[CameraView] | None = None):
        self.node, self.engine, self.spec = node, engine, spec
        self.views = views or env_views(num_envs)
        self.num_envs = len(self.views)  # cameras published (one per env unless `views`)
        self.images = CameraImages(engine)
        self._messages = {}  # (view, product) -> (Image, numpy view of its data)
        self.pubs = [{} for _ in self.views]  # view -> {product: (image pub, info pub)}
        self.infos = [self._camera_info(k) for k in range(len(self.views))]
        self.labels = String(data=json.dumps({str(k): v for k, v in sorted(labels.items())}))
        self.label_pubs = []
        for k in range(len(self.views)):
            pub = node.create_publisher(String, self.labels_topic(k), LATCHED_QOS)
            pub.publish(self.labels)
            self.label_pubs.append(pub)

    def labels_topic(self, view: int) -> str:
        return f"{self.views[view].namespace}/segmentation/labels"

    def topics(self, product: str, view: int) -> tuple[str, str]:
        ns = f"{self.views[view].namespace}/{product}"
        return f"{ns}/image_raw", f"{ns}/camera_info"

    def enable(self, products):
        """Creates the publishers of newly enabled products (publishers are never destroyed, so
        readers keep their connection when a product is switched off and on again)."""
        for env in range(self.num_envs):
            for product in products:
                if product in PRODUCTS and product not in self.pubs[env]:
                    image, info = self.topics(product, env)
                    self.pubs[env][product] = (self.node.create_publisher(Image, image, IMAGE_QOS),
                                               self.node.create_publisher(CameraInfo, info, IMAGE_QOS),
                                               self.node.create_publisher(
                                                   CompressedImage, f"{image}/{COMPRESSED[product]}", IMAGE_QOS))

    def _compress(self, product, image, header) -> CompressedImage:
        if product == "color":
            return compress_image(image, "jpeg", header=header)
        if product == "segmentation":
            return compress_image(image, "png", header=header)
        # inverse-depth steps fine enough that the camera's near plane still fits in 16 bits
        q = depth_quantization_for(self.spec.near, self.spec.far)
        return compress_depth(image, depth_max=self.spec.far, depth_quantization=q, header=header)

    def _camera_info(self, view: int) -> CameraInfo:
        s = self.spec
        fx, fy, cx, cy = s.intrinsics()
        cx, cy = cx - 0.5, cy - 0.5  # ROS: pixel centres at integer coordinates
        m = CameraInfo()
        m.header.frame_id = self.views[view].frame
        m.width, m.height = s.width, s.height
        m.distortion_model = "plumb_bob"
        m.d = [0.0] * 5
        m.k = [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0]
        m.r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        m.p = [fx, 0.0, cx, float(self.views[view].p_tx), 0.0, fy, cy, 0.0, 0.0, 0.0, 1.0, 0.0]
        return m

    def host_images(self, products) -> dict:
        """product -> [per env (H, W, ...) numpy image], after the frame that rendered them."""
        return self.images.read(products)

    def _message(self, view: int, product: str):
        """The view's Image of that product, made once: its data an array('B') the frame's
        images are converted into (rclpy copies it when publishing, so it is reused)."""
        key = (view, product)
        if key not in self._messages:
            s = self.spec
            encoding, size = ENCODINGS[product]
            img = Image()
            img.header.frame_id = self.views[view].frame
            img.height, img.width, img.encoding = s.height, s.width, encoding
            img.is_bigendian = 0
            img.step = s.width * size
            img.data = array("B", bytes(s.height * s.width * size))
            shape = (s.height, s.width, 3) if product == "color" else (s.height, s.width)
            self._messages[key] = (img, np.frombuffer(img.data, dtype=DTYPES[product]).reshape(shape))
        return self._messages[key]

    def publish(self, raw: dict, stamp, record=None):
        """Publishes a frame's images of every view from CameraImages.grab's `raw`: each converted
        straight into its message's data (no other copy); record(topic, msg) sees each message."""
        products = [p for p in PRODUCTS if p in raw]
        out = {p: [self._message(k, p)[1] for k in range(self.num_envs)] for p in products}
        images = self.images.convert(raw, out)
        for env in range(self.num_envs):
            info = self.infos[env]
            info.header.stamp = stamp
            for product in products:
                img = self._message(env, product)[0]
                img.header.stamp = stamp
                image_pub, info_pub, compressed_pub = self.pubs[env][product]
                image_pub.publish(img)
                info_pub.publish(info)
                if compressed_pub.get_subscription_count():
                    compressed_pub.publish(self._compress(product, images[product][env], img.header))
                if record is not None:  # the recorder serialises now: the reused data is safe
                    image_topic, info_topic = self.topics(product, env)
                    record(image_topic, img)
                    record(info_topic, info)


__all__ = ["CameraTopics", "CameraView", "ENCODINGS", "env_views", "IMAGE_QOS", "PRODUCTS", "camera_frame", "camera_namespace"]
