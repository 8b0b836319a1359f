"""Kinematic robot models: a dual-arm robot (two 7-DoF arms on a torso) loaded from URDF.

The action level needs forward kinematics and Jacobians of each arm, fast, many thousand times per
simulated action. We load the robot with pinocchio (``pin``, the maintained rigid-body library of
LAAS/INRIA) and keep **one reduced 7-DoF model per arm** (the other arm's joints are locked): the
controller of a single-arm action then only pays for one chain, and a two-arm action stacks the two
7-column Jacobians side by side (the arms share no joint, so the joint space is a direct sum).

The shipped robot (``data/dual_panda.urdf``) is written by :func:`dual_arm_urdf` from the published
kinematic parameters of the Franka Emika Panda (modified Denavit-Hartenberg table of the Franka
documentation, joint position and velocity limits of its datasheet): two such arms stand on the
front corners of a torso plate. Visual geometry is made of primitives (no meshes, nothing to
download) so PyBullet can draw it headless.

Frame convention (metres, radians): the world origin is the centre of the robot's base at table
height; x points forward (towards the human on the other side of the table), y to the robot's
left, z up. Arm ``left`` stands at ``y > 0``, arm ``right`` at ``y < 0``. The tool centre point
(TCP) of each arm lies between the fingertips; its z axis is the approach direction, so a top-down
grasp has the TCP z axis pointing along world ``-z``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from flexhrc.errors import FlexhrcError, OptionalDependencyError, UnknownNameError

if TYPE_CHECKING:  # pragma: no cover
    from numpy.typing import NDArray

    Array = NDArray[np.float64]
else:
    Array = np.ndarray

ARM_NAMES: tuple[str, ...] = ("left", "right")
DATA_DIR = Path(__file__).with_name("data")
DEFAULT_URDF = DATA_DIR / "dual_panda.urdf"

# Panda kinematics (Franka "Robot and interface specifications", modified DH written as URDF joint
# origins exactly as in franka_description): (xyz, rpy) of joint i in the frame of link i-1.
_H = math.pi / 2
PANDA_JOINT_ORIGINS: tuple[tuple[tuple[float, float, float], tuple[float, float, float]], ...] = (
    ((0.0, 0.0, 0.333), (0.0, 0.0, 0.0)),
    ((0.0, 0.0, 0.0), (-_H, 0.0, 0.0)),
    ((0.0, -0.316, 0.0), (_H, 0.0, 0.0)),
    ((0.0825, 0.0, 0.0), (_H, 0.0, 0.0)),
    ((-0.0825, 0.384, 0.0), (-_H, 0.0, 0.0)),
    ((0.0, 0.0, 0.0), (_H, 0.0, 0.0)),
    ((0.088, 0.0, 0.0), (_H, 0.0, 0.0)),
)
PANDA_FLANGE_Z = 0.107  # joint 7 axis to flange
PANDA_TCP_Z = 0.1034  # flange to the point between the fingertips (Franka hand)
PANDA_Q_MIN = (-2.8973, -1.7628, -2.8973, -3.0718, -2.8973, -0.0175, -2.8973)
PANDA_Q_MAX = (2.8973, 1.7628, 2.8973, -0.0698, 2.8973, 3.7525, 2.8973)
PANDA_V_MAX = (2.175, 2.175, 2.175, 2.175, 2.61, 2.61, 2.61)
# "Ready" pose of the Panda: elbow up, TCP about 0.3 m in front of the base, pointing down.
PANDA_Q_REST = (0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4)

# Placement of the two arm bases (world frame): on 10 cm plinths, 30 cm apart, beside the torso
# centre. A Panda reaches top-down with its wrist centre between ~0.21 m (elbow folded to the
# joint-4 limit) and ~0.70 m (arm stretched) from its shoulder; this placement keeps every point
# of the box x in [0.35, 0.65], y in [-0.2, 0.2], z in [0.05, 0.35] inside that shell for both
# arms (tests/action/test_robots.py checks it on a grid with the real inverse kinematics), while a
# point far to one side, e.g. (0.3, 0.7, 0.1), is reachable by the left arm only.
ARM_BASES: dict[str, tuple[float, float, float]] = {
    "left": (0.0, 0.15, 0.1),
    "right": (0.0, -0.15, 0.1),
}


def _fmt(values: tuple[float, ...] | list[float]) -> str:
    return " ".join(f"{v:.12g}" for v in values)


def _visual(geometry: str, material: str, origin: str = "") -> str:
    """URDF visual: a geometry element, a material name, the origin's attributes if any."""
    at = f"<origin {origin}/>" if origin else ""
    return (
        f'    <visual>{at}<geometry>{geometry}</geometry><material name="{material}"/></visual>\n'
    )


def _cylinder_between(vec: tuple[float, float, float], radius: float) -> str:
    """URDF visual of a cylinder from the link origin to ``vec`` (the next joint), for the view."""
    x, y, z = vec
    length = math.sqrt(x * x + y * y + z * z)
    if length < 1e-6:
        return ""
    pitch = math.atan2(math.hypot(x, y), z)
    yaw = math.atan2(y, x)
    origin = f'xyz="{_fmt((x / 2, y / 2, z / 2))}" rpy="0 {pitch:.6g} {yaw:.6g}"'
    return _visual(f'<cylinder radius="{radius}" length="{length:.6g}"/>', "white", origin)


# PyBullet wants an inertial block; the kinematic models ignore it.
_INERTIAL = (
    '    <inertial><mass value="1"/>'
    '<inertia ixx="0.01" ixy="0" ixz="0" iyy="0.01" iyz="0" izz="0.01"/></inertial>\n'
)


def dual_arm_urdf(bases: dict[str, tuple[float, float, float]] | None = None) -> str:
    """URDF text of the dual-arm robot (two Panda arms with hands on a torso plate)."""
    bases = dict(ARM_BASES if bases is None else bases)
    out = [
        '<?xml version="1.0"?>\n',
        "<!-- Generated by flexhrc.action.robots.dual_arm_urdf(); do not edit by hand.\n"
        "     Two Franka Emika Panda arms (published kinematic parameters and limits) on a torso.\n"
        "     Frame: origin at the centre of the base at table height,\n"
        "     x forward, y left, z up. -->\n",
        '<robot name="flexhrc_dual_panda">\n',
        '  <material name="white"><color rgba="0.92 0.92 0.92 1"/></material>\n',
        '  <material name="grey"><color rgba="0.35 0.35 0.38 1"/></material>\n',
        '  <material name="blue"><color rgba="0.2 0.4 0.8 1"/></material>\n',
        '  <link name="torso">\n',
        _visual('<box size="0.4 0.6 0.02"/>', "grey", 'xyz="-0.05 0 -0.01"'),
        _visual('<cylinder radius="0.07" length="0.1"/>', "grey", 'xyz="0 0.15 0.05"'),
        _visual('<cylinder radius="0.07" length="0.1"/>', "grey", 'xyz="0 -0.15 0.05"'),
        _visual('<box size="0.1 0.3 0.6"/>', "grey", 'xyz="-0.2 0 0.3"'),
        _visual('<sphere radius="0.1"/>', "blue", 'xyz="-0.2 0 0.68"'),
        _INERTIAL,
        "  </link>\n",
    ]
    for arm in ARM_NAMES:
        parent = "torso"
        origins = [*PANDA_JOINT_ORIGINS, ((0.0, 0.0, PANDA_FLANGE_Z), (0.0, 0.0, 0.0))]
        for i in range(7):
            xyz, rpy = origins[i]
            if i == 0:
                bx, by, bz = bases[arm]
                xyz = (xyz[0] + bx, xyz[1] + by, xyz[2] + bz)
            link = f"{arm}_link{i + 1}"
            out.append(
                f'  <joint name="{arm}_joint{i + 1}" type="revolute">\n'
                f'    <parent link="{parent}"/><child link="{link}"/>\n'
                f'    <origin xyz="{_fmt(xyz)}" rpy="{_fmt(rpy)}"/><axis xyz="0 0 1"/>\n'
                f'    <limit lower="{PANDA_Q_MIN[i]}" upper="{PANDA_Q_MAX[i]}" '
                f'velocity="{PANDA_V_MAX[i]}" effort="87"/>\n'
                "  </joint>\n"
            )
            nxt = origins[i + 1][0]
            out.append(
                f'  <link name="{link}">\n'
                + _visual('<sphere radius="0.06"/>', "grey")
                + _cylinder_between(nxt, 0.05)
                + _INERTIAL
                + "  </link>\n"
            )
            parent = link
        # Hand: flange -> hand (rotated -45 deg about z as on the real robot) -> TCP.
        out.append(
            f'  <joint name="{arm}_flange_joint" type="fixed">\n'
            f'    <parent link="{parent}"/><child link="{arm}_hand"/>\n'
            f'    <origin xyz="0 0 {PANDA_FLANGE_Z}" rpy="0 0 {-math.pi / 4:.12g}"/>\n'
            "  </joint>\n"
            f'  <link name="{arm}_hand">\n'
            + _visual('<box size="0.05 0.2 0.06"/>', "white", 'xyz="0 0 0.03"')
            + _visual('<box size="0.02 0.02 0.05"/>', "grey", 'xyz="0 0.04 0.08"')
            + _visual('<box size="0.02 0.02 0.05"/>', "grey", 'xyz="0 -0.04 0.08"')
            + _INERTIAL
            + "  </link>\n"
            f'  <joint name="{arm}_tcp_joint" type="fixed">\n'
            f'    <parent link="{arm}_hand"/><child link="{arm}_tcp"/>\n'
            f'    <origin xyz="0 0 {PANDA_TCP_Z}" rpy="0 0 0"/>\n'
            "  </joint>\n"
            f'  <link name="{arm}_tcp">\n' + _INERTIAL + "  </link>\n"
        )
    out.append("</robot>\n")
    return "".join(out)


_PIN: Any = None
_LWA: Any = None  # pinocchio's LOCAL_WORLD_ALIGNED frame, read once: kinematics runs each step


def _import_pinocchio() -> Any:
    global _PIN, _LWA
    if _PIN is None:
        try:
            import pinocchio
        except ImportError as exc:  # pragma: no cover - depends on the environment
            raise OptionalDependencyError("kinematic robot models", "sim", "pin") from exc
        _PIN, _LWA = pinocchio, pinocchio.ReferenceFrame.LOCAL_WORLD_ALIGNED
    return _PIN


@dataclass
class ArmModel:
    """Kinematics of one 7-DoF arm: a pinocchio model of its chain alone plus reusable data.

    ``q`` is always the arm's 7 joint angles. Poses are in the world frame (see module docstring).
    """

    name: str
    model: Any = field(repr=False)
    data: Any = field(repr=False)
    tcp_frame: int
    q_min: Array
    q_max: Array
    v_max: Array
    q_rest: Array
    shoulder_xyz: Array
    #: Largest shoulder (joint 2) to wrist centre (joint 6) distance within the joint limits.
    reach_m: float = 0.0
    #: Wrist centre seen from the TCP, in the TCP frame: distance back along the approach axis,
    #: and sideways (the Panda's last link is offset by 8.8 cm).
    hand_along_m: float = 0.0
    hand_lateral_m: float = 0.0

    @property
    def dof(self) -> int:
        return int(self.model.nq)

    def wrist_distance(self, tcp_xyz: Array) -> float:
        """Least shoulder-to-wrist-centre distance of a top-down TCP at ``tcp_xyz``: a necessary
        condition for reaching it is ``wrist_distance <= reach_m`` (cheap, no inverse
        kinematics)."""
        d = np.asarray(tcp_xyz, dtype=float) - self.shoulder_xyz
        dz = float(d[2]) + self.hand_along_m
        horiz = max(math.hypot(float(d[0]), float(d[1])) - self.hand_lateral_m, 0.0)
        return math.hypot(horiz, dz)

    def pose(self, q: Array) -> tuple[Array, Array]:
        """TCP position (3,) and rotation matrix (3, 3) at ``q``."""
        pin = _import_pinocchio()
        pin.forwardKinematics(self.model, self.data, q)
        oMf = pin.updateFramePlacement(self.model, self.data, self.tcp_frame)
        return oMf.translation.copy(), oMf.rotation.copy()

    def joint_positions(self, q: Array | list[float]) -> list[Array]:
        """Where each joint of the chain is at ``q`` (world frame), then the TCP: the polyline
        a viewer draws the arm as (the panel's 3D view)."""
        pin = _import_pinocchio()
        pin.forwardKinematics(self.model, self.data, np.asarray(q, dtype=float))
        points = [self.data.oMi[i].translation.copy() for i in range(1, self.model.njoints)]
        oMf = pin.updateFramePlacement(self.model, self.data, self.tcp_frame)
        return [*points, oMf.translation.copy()]

    def kinematics(self, q: Array) -> tuple[Array, Array, Array]:
        """TCP position, rotation and the 6x7 Jacobian (rows: linear, angular; world-aligned).

        One call to ``computeJointJacobians`` (forward kinematics plus all joint Jacobians) and one
        frame update per control step: that is the whole kinematic cost of a step.
        """
        pin = _PIN or _import_pinocchio()
        pin.computeJointJacobians(self.model, self.data, q)
        oMf = pin.updateFramePlacement(self.model, self.data, self.tcp_frame)
        J = pin.getFrameJacobian(self.model, self.data, self.tcp_frame, _LWA)
        return oMf.translation.copy(), oMf.rotation.copy(), J


@dataclass
class DualArmRobot:
    """The dual-arm robot: arms ``left`` and ``right``, each an :class:`ArmModel`."""

    urdf_path: Path
    arms: dict[str, ArmModel]

    @property
    def arm_names(self) -> tuple[str, ...]:
        return tuple(self.arms)

    def arm(self, name: str) -> ArmModel:
        try:
            return self.arms[name]
        except KeyError:
            raise UnknownNameError(
                f"unknown arm {name!r} (argument 'arm'); known arms: {', '.join(self.arms)}"
            ) from None

    def rest_configuration(self) -> dict[str, Array]:
        return {name: arm.q_rest.copy() for name, arm in self.arms.items()}


def load_robot(urdf: str | Path | None = None) -> DualArmRobot:
    """Load a dual-arm robot from URDF (default: the shipped ``dual_panda.urdf``).

    The URDF must contain, for each arm ``A`` in ``left``/``right``, joints ``A_joint1..7`` and a
    frame ``A_tcp``. The default robot is cached, and its data objects are reused: do not share
    one robot between threads.
    """
    if urdf is None:
        return _default_robot()
    return _load(Path(urdf))


@lru_cache(maxsize=1)
def _default_robot() -> DualArmRobot:
    return _load(DEFAULT_URDF)


def _load(path: Path) -> DualArmRobot:
    pin = _import_pinocchio()
    if not path.is_file():
        raise FlexhrcError(f"{path}: no such URDF file")
    try:
        full = pin.buildModelFromUrdf(str(path))
    except (RuntimeError, ValueError) as exc:
        raise FlexhrcError(f"{path}: cannot load URDF: {exc}") from None
    arms: dict[str, ArmModel] = {}
    q_neutral = pin.neutral(full)
    for name in ARM_NAMES:
        joint_names = [f"{name}_joint{i}" for i in range(1, 8)]
        missing = [j for j in joint_names if not full.existJointName(j)]
        if missing:
            raise FlexhrcError(f"{path}: arm {name!r} lacks joints {', '.join(missing)}")
        lock = [
            full.getJointId(n)
            for n in full.names[1:]
            if n not in joint_names and full.joints[full.getJointId(n)].nq > 0
        ]
        model = pin.buildReducedModel(full, lock, q_neutral)
        tcp = f"{name}_tcp"
        if not model.existFrame(tcp):
            raise FlexhrcError(f"{path}: arm {name!r} lacks the frame {tcp!r}")
        arm = ArmModel(
            name=name,
            model=model,
            data=model.createData(),
            tcp_frame=model.getFrameId(tcp),
            q_min=np.array(model.lowerPositionLimit, dtype=float),
            q_max=np.array(model.upperPositionLimit, dtype=float),
            v_max=np.array(model.velocityLimit, dtype=float),
            q_rest=np.clip(
                np.array(PANDA_Q_REST), model.lowerPositionLimit, model.upperPositionLimit
            ),
            shoulder_xyz=np.zeros(3),
        )
        _measure_workspace(pin, arm)
        arms[name] = arm
    return DualArmRobot(urdf_path=path, arms=arms)


def _measure_workspace(pin: Any, arm: ArmModel, samples: int = 2000) -> None:
    """Shoulder position, reach and hand geometry of ``arm``, measured on its model.

    The shoulder is the origin of joint 2 and the wrist centre that of joint 6 (the usual
    spherical-wrist-like split of a 7-DoF arm); the reach is the largest distance between them
    over ``samples`` seeded random configurations within the limits, plus 2 % (it only has to
    be a safe upper bound: :meth:`ArmModel.wrist_distance` rejects goals beyond it at once).
    """
    m, d = arm.model, arm.data
    pin.forwardKinematics(m, d, arm.q_rest)
    arm.shoulder_xyz = np.array(d.oMi[2].translation, dtype=float)
    oMf = pin.updateFramePlacement(m, d, arm.tcp_frame)
    v = oMf.rotation.T @ (d.oMi[6].translation - oMf.translation)
    arm.hand_along_m = float(-v[2])
    arm.hand_lateral_m = float(math.hypot(v[0], v[1]))
    rng = np.random.default_rng(0)
    best = 0.0
    for q in rng.uniform(arm.q_min, arm.q_max, size=(samples, arm.dof)):
        pin.forwardKinematics(m, d, q)
        best = max(best, float(np.linalg.norm(d.oMi[6].translation - d.oMi[2].translation)))
    arm.reach_m = 1.02 * best
