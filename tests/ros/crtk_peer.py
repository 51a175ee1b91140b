"""A stand-alone rclpy node for tests/ros, run as a subprocess (a separate DDS participant).

    python tests/ros/crtk_peer.py NAMESPACE

Subscribes NAMESPACE/state_command (crtk_msgs/StringStamped, reliable, depth 1); for each
command it sets its operating state (enable -> ENABLED, disable -> DISABLED, home -> is_homed,
pause -> PAUSED), publishes it on NAMESPACE/operating_state (crtk_msgs/OperatingState, reliable,
transient local, depth 100) and echoes the command on NAMESPACE/state_command_echo.
Serves NAMESPACE/operating_state (crtk_msgs/TriggerOperatingState). Prints READY once up;
exits when stdin closes. ROS_DOMAIN_ID comes from the environment.
"""
import sys
import threading

import rclpy
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

from crtk_msgs.msg import OperatingState, StringStamped
from crtk_msgs.srv import TriggerOperatingState

EVENT_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE,
                       durability=DurabilityPolicy.TRANSIENT_LOCAL)
COMMAND_QOS = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE,
                         durability=DurabilityPolicy.VOLATILE)


class Peer(Node):
    def __init__(self, ns):
        super().__init__("crtk_peer")
        self.ns = ns.rstrip("/")
        self.state = OperatingState(state=OperatingState.STATE_DISABLED, is_homed=False,
                                    is_busy=False)
        self.state_pub = self.create_publisher(OperatingState, f"{self.ns}/operating_state",
                                               EVENT_QOS)
        self.echo_pub = self.create_publisher(StringStamped, f"{self.ns}/state_command_echo",
                                              EVENT_QOS)
        self.create_subscription(StringStamped, f"{self.ns}/state_command", self.on_command,
                                 COMMAND_QOS)
        self.create_service(TriggerOperatingState, f"{self.ns}/operating_state", self.on_query)

    def stamped_state(self):
        self.state.header.stamp = self.get_clock().now().to_msg()
        self.state.header.frame_id = "PSM1"
        return self.state

    def on_command(self, msg):
        cmd = msg.string
        if cmd == "enable":
            self.state.state = OperatingState.STATE_ENABLED
        elif cmd == "disable":
            self.state.state = OperatingState.STATE_DISABLED
        elif cmd == "pause":
            self.state.state = OperatingState.STATE_PAUSED
        elif cmd == "resume":
            self.state.state = OperatingState.STATE_ENABLED
        elif cmd == "home":
            self.state.is_homed = True
        elif cmd == "unhome":
            self.state.is_homed = False
        self.echo_pub.publish(msg)
        self.state_pub.publish(self.stamped_state())

    def on_query(self, request, response):
        response.operating_state = self.stamped_state()
        return response


def main():
    ns = sys.argv[1] if len(sys.argv) > 1 else "/PSM1"
    rclpy.init()
    node = Peer(ns)
    executor = SingleThreadedExecutor()
    executor.add_node(node)
    threading.Thread(target=lambda: (sys.stdin.read(), rclpy.try_shutdown()), daemon=True).start()
    print("READY", flush=True)
    try:
        executor.spin()
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        node.destroy_node()
        rclpy.try_shutdown()


if __name__ == "__main__":
    main()
