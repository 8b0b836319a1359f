"""An independent ROS 2 client written with plain rclpy and std_msgs only — no flexhrc code —
as a lab's own operator interface or controller would be: it watches a cell's topics and speaks
its JSON protocol (docs/ros2.md, docs/protocol.md)."""

from __future__ import annotations

import json
import threading
import time
from typing import Any

import rclpy
from rclpy.duration import Duration
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy
from std_msgs.msg import String


class PlainClient:
    """Subscribes to topics, publishes JSON, keeps a liveliness token alive by heartbeats."""

    def __init__(self, cell: str, domain_id: int, name: str = "plain_client") -> None:
        self.base = f"/flexhrc/{cell}"
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain_id)
        self.node = rclpy.create_node(name, context=self.context)
        self.qos = QoSProfile(
            depth=100,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.VOLATILE,
        )
        self.lock = threading.Lock()
        self.received: dict[str, list[Any]] = {}
        self.pubs: dict[str, Any] = {}
        self.tokens: list[str] = []
        self.live = self.node.create_publisher(String, f"{self.base}/liveliness", self.qos)
        self.node.create_timer(0.1, self._beat)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.running = True
        self.thread = threading.Thread(target=self._spin, daemon=True)
        self.thread.start()

    def _spin(self) -> None:
        while self.running and self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except Exception:
                return

    def _beat(self) -> None:
        for key in list(self.tokens):
            self.live.publish(String(data=json.dumps({"key": key, "alive": True, "lease_s": 1.0})))

    def watch(self, topic: str) -> list[Any]:
        box: list[Any] = []
        self.received[topic] = box

        def on(msg: String) -> None:
            with self.lock:
                box.append(json.loads(msg.data))

        self.node.create_subscription(String, f"{self.base}/{topic}", on, self.qos)
        return box

    def publish(self, topic: str, payload: dict[str, Any], wait_s: float = 10.0) -> None:
        self.publish_raw(topic, json.dumps(payload), wait_s)

    def publish_raw(self, topic: str, text: str, wait_s: float = 10.0) -> None:
        pub = self.pubs.get(topic)
        if pub is None:
            pub = self.pubs[topic] = self.node.create_publisher(
                String, f"{self.base}/{topic}", self.qos
            )
        deadline = time.monotonic() + wait_s
        while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
            time.sleep(0.01)  # DDS delivers only to subscribers it has discovered
        pub.publish(String(data=text))

    def publish_pose(self, obj: str, xyz: list[float], wait_s: float = 10.0) -> None:
        """An object pose as outside perception sends it (geometry_msgs/PoseStamped, world)."""
        from geometry_msgs.msg import PoseStamped

        topic = f"objects/{obj}/pose"
        pub = self.pubs.get(topic)
        if pub is None:
            pub = self.pubs[topic] = self.node.create_publisher(
                PoseStamped, f"{self.base}/{topic}", self.qos
            )
        deadline = time.monotonic() + wait_s
        while pub.get_subscription_count() == 0 and time.monotonic() < deadline:
            time.sleep(0.01)
        m = PoseStamped()
        m.header.frame_id = "world"
        m.pose.position.x, m.pose.position.y, m.pose.position.z = (float(v) for v in xyz)
        m.pose.orientation.w = 1.0
        pub.publish(m)

    def close(self) -> None:
        for key in self.tokens:
            self.live.publish(String(data=json.dumps({"key": key, "alive": False})))
        # the goodbyes reach every matched subscriber before the node goes (reliable QoS)
        self.live.wait_for_all_acked(Duration(seconds=2))
        self.running = False
        self.thread.join(2)
        self.executor.shutdown()
        self.node.destroy_node()
        self.context.try_shutdown()
