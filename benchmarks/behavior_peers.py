"""Benchmark: what sharing a task between two robots adds to a tick (issue 14: <= 1 ms over Zenoh).

The 10 000-node network of ``behavior_ticks.py`` (complete 5-ary tree, random THEN/AND/OR) is
ticked (1) alone, one robot, one arm; (2) as two robots, each its own copy of the network and
one arm, with :class:`flexhrc.behavior.peers.PeerLink` over the in-process peer bus; (3) the
same over Zenoh — two Zenoh sessions in this process, connected on 127.0.0.1 (multicast
scouting off), one per robot. A robot's tick in (2)/(3) is its peer deliveries (``flush``) plus
its network's tick; the medians over the timed ticks (after a warm-up in which claims and
progress are flowing) and the difference to (1) are printed.

Usage::

    python3 benchmarks/behavior_peers.py [--nodes 10000] [--ticks 80] [--warmup 40] [--json]
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "src"))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from behavior_ticks import tree_spec

from flexhrc.behavior import BehaviorNetwork, NetworkParams, build_task, random_world
from flexhrc.behavior.messages import to_wire
from flexhrc.behavior.peers import PeerLink, from_wire, robot_world
from flexhrc.transport import InProcessBus

TARGET_ADDED_MS = 1.0


def _median_ms(times: list[float]) -> float:
    return round(statistics.median(times) * 1e3, 4)


def alone(task, ticks: int, warmup: int) -> float:
    world = robot_world(random_world(task.behaviors, seed=1), 0, "robot1")
    net = BehaviorNetwork(task, world, NetworkParams(seed=1))
    times = []
    for k in range(warmup + ticks):
        t0 = time.perf_counter()
        net.tick()
        if k >= warmup:
            times.append(time.perf_counter() - t0)
    return _median_ms(times)


def team(task, ticks: int, warmup: int, buses: list, flushes) -> float:
    base = random_world(task.behaviors, seed=1)
    names = ["robot1", "robot2"]
    nets = []
    for k, name in enumerate(names):
        net = BehaviorNetwork(task, robot_world(base, k, name), NetworkParams(seed=1))
        PeerLink(name, names, buses[k], net)
        nets.append(net)
    times = []
    for k in range(warmup + ticks):
        for i, net in enumerate(nets):
            t0 = time.perf_counter()
            flushes[i]()
            net.tick()
            if k >= warmup and i == 0:
                times.append(time.perf_counter() - t0)
        time.sleep(0.0005)  # let Zenoh's threads deliver between rounds, as between ticks
    return _median_ms(times)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nodes", type=int, default=10_000)
    ap.add_argument("--ticks", type=int, default=80)
    ap.add_argument("--warmup", type=int, default=40)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    task = build_task(tree_spec(args.nodes), f"<bench {args.nodes}>")
    rows = {"nodes": task.size, "alone_ms": alone(task, args.ticks, args.warmup)}
    bus = InProcessBus()
    rows["inprocess_team_ms"] = team(
        task, args.ticks, args.warmup, [bus, bus], [bus.flush, lambda: 0]
    )
    try:
        from flexhrc.transport.zenoh import (
            ZenohTransport,
            json_decode,
            json_encode,
            zenoh_config,
        )
    except Exception as exc:  # the zenoh extra is optional
        rows["zenoh_team_ms"] = None
        rows["zenoh_error"] = str(exc)
    else:
        codec = {
            "encode": lambda m: json_encode(to_wire(m)),
            "decode": lambda b: from_wire(json_decode(b)),
        }
        # the first session takes a port the system gives it; the second connects there
        z1 = ZenohTransport(zenoh_config(listen=["tcp/127.0.0.1:0"]), **codec)
        z2 = ZenohTransport(zenoh_config(connect=z1.locators()), **codec)
        time.sleep(0.5)  # the two sessions find each other
        try:
            rows["zenoh_team_ms"] = team(
                task, args.ticks, args.warmup, [z1, z2], [z1.flush, z2.flush]
            )
        finally:
            z1.close()
            z2.close()
    for key in ("inprocess_team_ms", "zenoh_team_ms"):
        if rows.get(key) is not None:
            rows[key.replace("_ms", "_added_ms")] = round(rows[key] - rows["alone_ms"], 4)
    if args.json:
        print(json.dumps(rows, indent=2))
        return
    print(f"network: {rows['nodes']} nodes; median ms per tick of one robot")
    print(f"  alone                       {rows['alone_ms']:8.3f}")
    print(
        f"  two robots, in-process bus  {rows['inprocess_team_ms']:8.3f}"
        f"  (+{rows['inprocess_team_added_ms']:.3f})"
    )
    if rows.get("zenoh_team_ms") is not None:
        added = rows["zenoh_team_added_ms"]
        print(f"  two robots, Zenoh           {rows['zenoh_team_ms']:8.3f}  (+{added:.3f})")
        verdict = "met" if added <= TARGET_ADDED_MS else "NOT met"
        print(f"target: Zenoh adds <= {TARGET_ADDED_MS:.0f} ms per tick — {verdict}")
    else:
        print(f"  Zenoh: not measured ({rows.get('zenoh_error')})")


if __name__ == "__main__":
    main()
