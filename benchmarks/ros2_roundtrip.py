"""Benchmark: command -> ack round trip through ROS 2 on localhost (issue 15: median <= 5 ms).

Two separate processes on one host, the cell's JSON messages on ``std_msgs/String`` topics
(Fast DDS, ``ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST``, a random ``ROS_DOMAIN_ID``):

* *transport*: this process publishes a protocol ``command`` on ``/flexhrc/<cell>/cmd/left``;
  an agent process answers every command with its ``ack`` on ``/flexhrc/<cell>/ack`` as soon as
  it arrives — the round trip of the bridge itself (both transports in ``flush`` delivery, as
  the cell uses them);
* *arm node*: the same through ``flexhrc ros2 arm table_assembly --arm left`` executing
  ``rest(left)`` from rest with the cell's ``realtime`` 0 (answer at once) — the round trip plus
  the node's kinematic simulation of a motion that is already over.

The first ``--warmup`` round trips are not timed. Median, 90th percentile and maximum in ms.

Usage::

    python3 benchmarks/ros2_roundtrip.py [--n 500] [--warmup 50] [--json]
"""

from __future__ import annotations

import argparse
import json
import os
import random
import statistics
import subprocess
import sys
import textwrap
import time
import uuid
from pathlib import Path

SRC = Path(__file__).resolve().parents[1] / "src"
sys.path.insert(0, str(SRC))

TARGET_MS = 5.0

_ECHO = textwrap.dedent(
    """
    import sys
    from flexhrc.ros2.transport import Ros2Transport
    t = Ros2Transport(prefix=sys.argv[1])
    def answer(m):
        t.publish("ack", {"v": 1, "type": "ack", "id": m["id"], "agent": "left",
                          "status": "done", "reason": None, "t": m["t"]})
    t.subscribe("cmd/left", answer)
    t.declare_token("alive/left")
    while True:
        if t.wait(0.5):
            t.flush()
    """
)


def _env(domain: int) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join(p for p in (str(SRC), env.get("PYTHONPATH", "")) if p)
    env["ROS_DOMAIN_ID"] = str(domain)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    return env


def measure(argv: list[str], cell: str, domain: int, action: str, n: int, warmup: int) -> dict:
    from flexhrc.ros2.transport import Ros2Transport

    os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    proc = subprocess.Popen(argv, env=_env(domain), stderr=subprocess.DEVNULL)
    bus = Ros2Transport(prefix=f"flexhrc/{cell}", domain_id=domain)
    got: dict[int, float] = {}
    alive: list[str] = []
    bus.subscribe("ack", lambda m: got.setdefault(m["id"], time.perf_counter()))
    bus.watch_liveliness("alive/*", lambda k, a: alive.append(k) if a else None)
    try:
        deadline = time.monotonic() + 60
        while not alive and time.monotonic() < deadline:
            if bus.wait(0.2):
                bus.flush()
        if not alive:
            raise SystemExit("the agent never came up")
        bus.wait_matched("cmd/left", minimum=1, timeout=10)
        times: list[float] = []
        for i in range(n + warmup):
            t0 = time.perf_counter()
            bus.publish(
                "cmd/left",
                {
                    "v": 1,
                    "type": "command",
                    "id": i + 1,
                    "action": action,
                    "agents": ["left"],
                    "t": 0.0,
                    "expected_s": 1.0,
                    "realtime": 0.0,
                },
            )
            limit = time.monotonic() + 10
            while i + 1 not in got:
                if time.monotonic() > limit:
                    raise SystemExit(f"no ack for command {i + 1} within 10 s")
                if bus.wait(1.0):
                    bus.flush()
            if i >= warmup:
                times.append((got[i + 1] - t0) * 1e3)
        times.sort()
        return {
            "n": len(times),
            "median_ms": round(statistics.median(times), 3),
            "p90_ms": round(times[int(0.9 * (len(times) - 1))], 3),
            "max_ms": round(times[-1], 3),
        }
    finally:
        bus.close()
        proc.terminate()
        proc.wait(10)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--n", type=int, default=500, help="timed round trips per case (500)")
    ap.add_argument("--warmup", type=int, default=50)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    domain = random.SystemRandom().randint(1, 100)
    out = {}
    cell = f"b{uuid.uuid4().hex[:8]}"
    out["transport"] = measure(
        [sys.executable, "-c", _ECHO, f"flexhrc/{cell}"], cell, domain, "rest(left)",
        args.n, args.warmup,
    )  # fmt: skip
    cell = f"b{uuid.uuid4().hex[:8]}"
    out["arm_node"] = measure(
        [sys.executable, "-m", "flexhrc", "ros2", "arm", "table_assembly", "--arm", "left",
         "--cell", cell, "--quiet"],
        cell, domain, "rest(left)", max(50, args.n // 5), 10,
    )  # fmt: skip
    out["target_ms"] = TARGET_MS
    out["ok"] = out["transport"]["median_ms"] <= TARGET_MS
    if args.json:
        print(json.dumps(out, indent=2))
    else:
        for case in ("transport", "arm_node"):
            r = out[case]
            print(
                f"{case:<10} n={r['n']:<4} median {r['median_ms']:.3f} ms  "
                f"p90 {r['p90_ms']:.3f} ms  max {r['max_ms']:.3f} ms"
            )
        print(f"target: median <= {TARGET_MS} ms -> {'OK' if out['ok'] else 'MISSED'}")
    return 0 if out["ok"] else 1


if __name__ == "__main__":
    sys.exit(main())
