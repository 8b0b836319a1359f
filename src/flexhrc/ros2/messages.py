"""Standard ROS 2 messages built from flexhrc's data, and read back into it.

Only message packages that ship as PyPI wheels are used (``std_msgs``, ``geometry_msgs``,
``sensor_msgs``, ``trajectory_msgs``, ``visualization_msgs``), so nothing needs compiling:

* :func:`joint_state` — ``sensor_msgs/JointState`` of one arm (``<arm>_joint1..7``, radians);
* :func:`pose_stamped` — ``geometry_msgs/PoseStamped`` of an end effector or an object;
* :func:`joint_trajectory` — a kinematic-simulator :class:`~flexhrc.action.simulator.Trajectory`
  as ``trajectory_msgs/JointTrajectory`` (what a ``joint_trajectory_controller`` executes);
* :func:`marker_array` — the knowledge base's objects (each by its type and size) and the
  running commands' targets as ``visualization_msgs/MarkerArray`` for RViz, with ``DELETE``
  markers for the arrows of finished commands;
* :func:`percept_from_pose` and :func:`imu_sample` — object poses and wrist IMU readings coming
  from perception that runs outside flexhrc, as plain dicts.

Every function checks its numbers: NaN or infinity raises a ``ValueError`` naming the field.
"""

from __future__ import annotations

import math
import zlib
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

from flexhrc.events import position_problem
from flexhrc.ros2._deps import msg

Vec3 = tuple[float, float, float]

__all__ = [
    "imu_sample",
    "joint_names",
    "joint_state",
    "joint_trajectory",
    "marker_array",
    "object_shape",
    "percept_from_pose",
    "pose_stamped",
    "quaternion_from_matrix",
    "stamp",
    "stamp_seconds",
    "yaw_from_quaternion",
]

WORLD_FRAME = "world"


def joint_names(arm: str, dof: int = 7) -> list[str]:
    """Joint names of one arm, as in the shipped URDF (``left_joint1`` ... ``left_joint7``)."""
    return [f"{arm}_joint{i}" for i in range(1, dof + 1)]


def _finite(values: Iterable[float], what: str) -> list[float]:
    out = [float(v) for v in values]
    for v in out:
        if not math.isfinite(v):
            raise ValueError(f"{what}: {v} is not a finite number")
    return out


def stamp(seconds: float) -> Any:
    """``builtin_interfaces/Time`` for ``seconds`` (wall or simulated time)."""
    if not math.isfinite(seconds) or seconds < 0:
        raise ValueError(f"time stamp must be a finite non-negative number, not {seconds}")
    return _time("Time", seconds)


def _time(kind: str, seconds: float) -> Any:
    """A ``builtin_interfaces`` ``Time`` or ``Duration`` of ``seconds`` (>= 0)."""
    t = msg("builtin_interfaces.msg", kind)()
    t.sec = int(seconds)
    t.nanosec = min(round((seconds - t.sec) * 1e9), 999_999_999)
    return t


def stamp_seconds(t: Any) -> float:
    return float(t.sec) + float(t.nanosec) * 1e-9


def _header(frame_id: str, seconds: float) -> Any:
    h = msg("std_msgs.msg", "Header")()
    h.frame_id = frame_id
    h.stamp = stamp(seconds)
    return h


def joint_state(
    names: Sequence[str],
    positions: Sequence[float],
    seconds: float,
    velocities: Sequence[float] | None = None,
) -> Any:
    """``sensor_msgs/JointState`` (no efforts: the kinematic simulator has none)."""
    if len(names) != len(positions):
        raise ValueError(f"{len(names)} joint names but {len(positions)} positions")
    m = msg("sensor_msgs.msg", "JointState")()
    m.header = _header("", seconds)
    m.name = list(names)
    m.position = _finite(positions, "joint position")
    if velocities is not None:
        if len(velocities) != len(names):
            raise ValueError(f"{len(names)} joint names but {len(velocities)} velocities")
        m.velocity = _finite(velocities, "joint velocity")
    return m


def quaternion_from_matrix(R: Any) -> tuple[float, float, float, float]:
    """Unit quaternion ``(x, y, z, w)`` of a 3x3 rotation matrix (Shepperd's method: the
    largest of the trace and the diagonal terms is the divisor, so it stays accurate near 180
    degrees)."""
    r = [[float(R[i][j]) for j in range(3)] for i in range(3)]
    trace = r[0][0] + r[1][1] + r[2][2]
    if trace > 0:
        s = 2.0 * math.sqrt(trace + 1.0)
        q = [(r[2][1] - r[1][2]) / s, (r[0][2] - r[2][0]) / s, (r[1][0] - r[0][1]) / s, s / 4]
    else:  # i: the largest diagonal term; (i, j, k) in cyclic order
        i = 0 if r[0][0] > r[1][1] and r[0][0] > r[2][2] else (1 if r[1][1] > r[2][2] else 2)
        j, k = (i + 1) % 3, (i + 2) % 3
        s = 2.0 * math.sqrt(1.0 + r[i][i] - r[j][j] - r[k][k])
        q = [0.0, 0.0, 0.0, (r[k][j] - r[j][k]) / s]
        q[i], q[j], q[k] = s / 4, (r[j][i] + r[i][j]) / s, (r[k][i] + r[i][k]) / s
    n = math.sqrt(sum(v * v for v in q))
    return (q[0] / n, q[1] / n, q[2] / n, q[3] / n)


def yaw_from_quaternion(x: float, y: float, z: float, w: float) -> float:
    """Rotation about the world z axis (radians) of a quaternion."""
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def pose_stamped(
    position: Sequence[float],
    seconds: float,
    orientation: Sequence[float] = (0.0, 0.0, 0.0, 1.0),
    frame_id: str = WORLD_FRAME,
) -> Any:
    """``geometry_msgs/PoseStamped``; ``orientation`` is a quaternion ``(x, y, z, w)``."""
    p = _finite(position, "position")
    q = _finite(orientation, "orientation")
    if len(p) != 3 or len(q) != 4:
        raise ValueError("a pose needs 3 position values and a 4-value quaternion")
    m = msg("geometry_msgs.msg", "PoseStamped")()
    m.header = _header(frame_id, seconds)
    m.pose.position.x, m.pose.position.y, m.pose.position.z = p
    o = m.pose.orientation
    o.x, o.y, o.z, o.w = q
    return m


def joint_trajectory(
    names: Sequence[str],
    times: Sequence[float],
    positions: Sequence[Sequence[float]],
    seconds: float,
    *,
    max_points: int = 50,
) -> Any:
    """``trajectory_msgs/JointTrajectory`` through at most ``max_points`` samples of a motion
    (always its first and last), each with its ``time_from_start`` and finite-difference
    velocities (zero at both ends, so a controller starts and ends at rest)."""
    n = len(times)
    if n == 0 or n != len(positions):
        raise ValueError(f"a trajectory needs as many times ({n}) as positions ({len(positions)})")
    if max_points < 2:
        raise ValueError("max_points must be at least 2")
    keep = (
        sorted({round(i * (n - 1) / (max_points - 1)) for i in range(max_points)})
        if n > max_points
        else list(range(n))
    )
    Point = msg("trajectory_msgs.msg", "JointTrajectoryPoint")
    m = msg("trajectory_msgs.msg", "JointTrajectory")()
    m.header = _header("", seconds)
    m.joint_names = list(names)
    t0 = float(times[0])
    rows = [(float(times[i]) - t0, _finite(positions[i], "trajectory position")) for i in keep]
    for k, (t, q) in enumerate(rows):
        if len(q) != len(names):
            raise ValueError(f"{len(names)} joint names but a point with {len(q)} positions")
        p = Point()
        p.positions = q
        if 0 < k < len(rows) - 1:
            (ta, qa), (tb, qb) = rows[k - 1], rows[k + 1]
            dt = tb - ta
            p.velocities = [(b - a) / dt if dt > 0 else 0.0 for a, b in zip(qa, qb, strict=True)]
        else:
            p.velocities = [0.0] * len(q)
        p.time_from_start = _time("Duration", t)
        m.points.append(p)
    return m


_COLOURS = {
    "leg": (0.80, 0.55, 0.25, 1.0),
    "tabletop": (0.60, 0.40, 0.20, 0.8),
    "place": (0.20, 0.50, 0.90, 0.6),
    "obstacle": (0.90, 0.20, 0.20, 0.5),
    "target": (0.10, 0.90, 0.20, 0.9),
}
#: Object types that are agents, not things: the joint states show the arms.
AGENT_TYPES = ("arm", "robot", "human")
#: The size of an object whose record gives none (m).
DEFAULT_SIZE = 0.03


def _stable_id(name: str) -> int:
    """A marker id from a name, the same in every process and run (RViz updates by id)."""
    return zlib.crc32(name.encode("utf-8")) & 0x3FFFFFFF


def _colour(type_: str) -> tuple[float, float, float, float]:
    if type_ in _COLOURS:
        return _COLOURS[type_]
    h = zlib.crc32(type_.encode("utf-8"))  # a fixed colour per type, not too dark
    return (0.3 + 0.6 * (h & 0xFF) / 255, 0.3 + 0.6 * ((h >> 8) & 0xFF) / 255,
            0.3 + 0.6 * ((h >> 16) & 0xFF) / 255, 0.9)  # fmt: skip


def _dim(size: Mapping[str, Any], *keys: str) -> float | None:
    for k in keys:
        v = size.get(k)
        if isinstance(v, int | float) and math.isfinite(v) and v > 0:
            return float(v)
    return None


def object_shape(o: Any) -> tuple[str, tuple[float, float, float]]:
    """The marker shape (``CUBE``, ``CYLINDER``, ``SPHERE``) and scale of a knowledge-base
    object, from its type (the table's legs, tabletop, places and obstacles) or else from its
    size: a ``radius``/``diameter`` with a ``length``/``height`` is a cylinder, alone a sphere;
    ``length``/``width``/``depth``/``height`` make a box (x: length, else width; y: width when
    a length is given, else depth); no size: a small cube (a disc for a place)."""
    size = dict(o.size or {})
    if o.type == "leg":
        return "CYLINDER", (
            _dim(size, "diameter") or 0.04,
            _dim(size, "diameter") or 0.04,
            _dim(size, "length") or 0.3,
        )
    if o.type == "obstacle":
        r = _dim(dict(o.attrs), "radius") or _dim(size, "radius") or 0.05
        return "SPHERE", (2 * r, 2 * r, 2 * r)
    if o.type == "tabletop":
        return "CUBE", (
            _dim(size, "width") or 0.3,
            _dim(size, "depth") or 0.4,
            _dim(size, "height") or 0.02,
        )
    radius = _dim(size, "radius")
    dia = _dim(size, "diameter") or (2 * radius if radius else None)
    tall = _dim(size, "length", "height")
    if dia is not None:
        return ("CYLINDER", (dia, dia, tall)) if tall else ("SPHERE", (dia, dia, dia))
    x = _dim(size, "length", "width")
    y = _dim(size, "width", "depth") if "length" in size else _dim(size, "depth")
    z = _dim(size, "height")
    if x is None and y is None and z is None:
        if o.type == "place":
            return "CYLINDER", (DEFAULT_SIZE, DEFAULT_SIZE, 0.002)
        return "CUBE", (DEFAULT_SIZE, DEFAULT_SIZE, DEFAULT_SIZE)
    return "CUBE", (x or DEFAULT_SIZE, y or x or DEFAULT_SIZE, z or DEFAULT_SIZE)


def marker_array(
    objects: Iterable[Any],
    seconds: float,
    *,
    commands: Mapping[int, tuple[str, Sequence[float]]] | None = None,
    deleted: Iterable[int] = (),
    skip: Iterable[str] = (),
    frame_id: str = WORLD_FRAME,
    namespace: str = "flexhrc",
) -> Any:
    """Knowledge-base objects (:class:`~flexhrc.knowledge.base.ObjectRecord`) as markers, every
    one by its type and size (:func:`object_shape`) with a text label — agents (types
    :data:`AGENT_TYPES`, or named in ``skip``) are left out, the joint states show the arms;
    ``commands`` (command id -> (label, position), where a
    running command's arm is going) as green arrows pointing down at them; ``deleted`` command
    ids as ``DELETE`` markers of their arrows (a finished command's arrow goes from RViz).

    Ids are stable across arrays and processes: objects (namespace ``namespace``) by name,
    command arrows (``<namespace>/commands``) by command id, so RViz updates them in place."""
    Marker = msg("visualization_msgs.msg", "Marker")
    out = msg("visualization_msgs.msg", "MarkerArray")()
    header = _header(frame_id, seconds)
    skipped = set(skip)

    def add(m: Any, ns: str, mid: int) -> None:
        m.header = header
        m.ns = ns
        m.id = mid
        m.action = Marker.ADD
        if m.pose.orientation.w == 0.0 and m.pose.orientation.y == 0.0:
            m.pose.orientation.w = 1.0
        out.markers.append(m)

    def arrow(label: str, pos: Sequence[float], ns: str, mid: int) -> None:
        x, y, z = _finite(pos, f"target of {label}")
        m = Marker()
        m.type = Marker.ARROW
        start, end = msg("geometry_msgs.msg", "Point")(), msg("geometry_msgs.msg", "Point")()
        start.x, start.y, start.z = x, y, z + 0.12
        end.x, end.y, end.z = x, y, z
        m.points = [start, end]
        m.scale.x, m.scale.y, m.scale.z = 0.01, 0.02, 0.03
        m.color.r, m.color.g, m.color.b, m.color.a = _COLOURS["target"]
        m.text = label
        add(m, ns, mid)

    for o in sorted(objects, key=lambda r: r.id):
        if o.type in AGENT_TYPES or o.id in skipped:
            continue
        x, y, z = _finite(o.position, f"position of {o.id}")
        shape, (sx, sy, sz) = object_shape(o)
        m = Marker()
        m.type = getattr(Marker, shape)
        m.scale.x, m.scale.y, m.scale.z = sx, sy, sz
        if o.type == "leg":
            # a leg lies on the table until it is fixed: then it stands under its bolt
            if o.fixed:
                z = z - sz / 2
            else:
                m.pose.orientation.y = math.sqrt(0.5)
                m.pose.orientation.w = math.sqrt(0.5)
                z = z + sx / 2
        m.pose.position.x, m.pose.position.y, m.pose.position.z = x, y, z
        m.color.r, m.color.g, m.color.b, m.color.a = _colour(o.type)
        m.text = o.id
        base = 2 * _stable_id(o.id)
        add(m, namespace, base)
        label = Marker()
        label.type = Marker.TEXT_VIEW_FACING
        label.text = o.id
        label.scale.z = 0.025
        label.pose.position.x, label.pose.position.y = x, y
        label.pose.position.z = z + 0.05 + (0.0 if o.type == "leg" else sz / 2)
        label.color.r = label.color.g = label.color.b = label.color.a = 1.0
        add(label, namespace, base + 1)
    for cid, (label, pos) in sorted((commands or {}).items()):
        arrow(label, pos, f"{namespace}/commands", int(cid))
    for cid in sorted(set(deleted)):
        gone = Marker()
        gone.header = header
        gone.ns = f"{namespace}/commands"
        gone.id = int(cid)
        gone.action = Marker.DELETE
        out.markers.append(gone)
    return out


def percept_from_pose(name: str, m: Any) -> dict[str, Any]:
    """An object pose from outside perception (``geometry_msgs/PoseStamped`` in the world
    frame) as a plain dict: ``{"object", "position", "orientation" (x, y, z, w), "yaw", "t"}``.
    Raises ``ValueError`` for a non-finite pose, a position outside the workspace (the cell
    protocol's own check, :func:`flexhrc.events.position_problem`) or a frame other than
    ``world`` (or empty)."""
    if m.header.frame_id not in ("", WORLD_FRAME):
        raise ValueError(
            f"pose of {name!r} is in frame {m.header.frame_id!r}; flexhrc expects {WORLD_FRAME!r}"
        )
    p = m.pose.position
    q = m.pose.orientation
    position = _finite((p.x, p.y, p.z), f"position of {name}")
    said = position_problem(position, f"position of {name}")
    if said is not None:
        raise ValueError(said)
    quat = _finite((q.x, q.y, q.z, q.w), f"orientation of {name}")
    norm = math.sqrt(sum(v * v for v in quat))
    # an unset orientation (all zeros) is the identity, as RViz reads it
    quat = [0.0, 0.0, 0.0, 1.0] if norm < 1e-6 else [v / norm for v in quat]
    return {
        "object": name,
        "position": [round(v, 6) for v in position],
        "orientation": [round(v, 9) for v in quat],
        "yaw": round(yaw_from_quaternion(*quat), 6),
        "t": round(stamp_seconds(m.header.stamp), 6),
    }


def imu_sample(m: Any) -> dict[str, Any]:
    """A wrist IMU reading (``sensor_msgs/Imu``) as ``{"t", "accel", "gyro"}`` (m/s^2, rad/s),
    the samples flexhrc's human action recognition windows."""
    a, g = m.linear_acceleration, m.angular_velocity
    return {
        "t": round(stamp_seconds(m.header.stamp), 6),
        "accel": _finite((a.x, a.y, a.z), "linear_acceleration"),
        "gyro": _finite((g.x, g.y, g.z), "angular_velocity"),
    }
