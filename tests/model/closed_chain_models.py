"""Closed-chain mechanisms written after published geometry, each with an independent closed form.

Every model is planar (joint axes along z, loops closed by a pin cut with mask [x, y]) so its
loop closure is a chain of circle intersections; the closed form picks the intersection on the
side of the home assembly (the sign of a cross product, constant along any path that meets no
constraint singularity), i.e. the assembly connected to home.

* ``xarm_gripper``: one side of the UFACTORY xArm gripper, a parallelogram (MuJoCo Menagerie
  ``ufactory_xarm7/hand.xml``: outer knuckle pivot (0.035, 0.059098), finger pivot at
  (0.035465, 0.042039) on it, inner knuckle pivot (0.02, 0.074098), the connect anchor
  (-0.015, 0.015) on the finger; every joint in [0, 0.85] rad; the (y, z) plane mapped to
  (x, y)). Closed form: q_finger = q_inner = q_driver.
* ``robotiq_fourbar``: one side of the Robotiq 2F-85 (MuJoCo Menagerie ``robotiq_2f85/2f85.xml``:
  driver pivot (0.0306011, 0.054904), coupler origin (0.0315, -0.0041) on the driver and the
  follower anchor at (0.0060989, 0.047596) on the coupler, spring-link pivot (0.0132, 0.0609),
  follower origin (0.055, 0.0375) on it with its joint at (-0.018, 0.0065); ranges driver
  [0, 0.8], spring link [-0.29670597283, 0.8], follower [-0.872664, 0.872664] rad), with the
  coupler joint held at 0 (its free-motion position), so driver + coupler is one crank.
* ``cassie_leg``: a leg closed by a rod, Cassie-like proportions (thigh 0.12 m from hip pitch to
  knee, shin 0.4348 m, achilles rod 0.5012 m from a point 0.05 m off the thigh axis to a heel
  point (-0.03, 0.06) m on the tarsus; planar).
* ``slider_crank``: an in-line-offset slider-crank, crank r = 0.05 m, rod l = 0.2 m, offset
  e = 0.01 m (closed form x = r cos q + sqrt(l^2 - (r sin q - e)^2)); stroke limits on the
  slider.
* ``watt_six_bar``: a Watt II six-bar (two four-bars in series through a ternary rocker):
  ground pivots O2 (0, 0), O4 (0.4, 0), O6 (0.75, 0.05); crank 0.1, coupler 0.35, ternary rocker
  O4-B 0.2 and O4-C 0.15 at +40 deg, coupler 0.3, output rocker 0.25 m.
"""

from __future__ import annotations

import numpy as np


def cross2(a, b):
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def _rot(a):
    c, s = np.cos(a), np.sin(a)
    return np.stack([np.stack([c, -s], -1), np.stack([s, c], -1)], -2)


def circle_meet(c1, r1, c2, r2, sign):
    """Intersection of circles (c1, r1), (c2, r2) (batches (m, 2)) on the side ``sign`` of
    cross(p - c1, c2 - p) (nan where they do not meet)."""
    d = c2 - c1
    dist = np.linalg.norm(d, axis=-1)
    a = (r1**2 - r2**2 + dist**2) / (2 * dist)
    with np.errstate(invalid="ignore"):
        h = np.sqrt(r1**2 - a**2)
    u = d / dist[:, None]
    n = np.stack([-u[:, 1], u[:, 0]], -1)
    out = []
    for s in (1.0, -1.0):
        p = c1 + a[:, None] * u + s * h[:, None] * n
        out.append(p)
    p1, p2 = out
    cr = lambda p: cross2(p - c1, c2 - p)  # noqa: E731
    return np.where((np.sign(cr(p1)) == sign)[:, None], p1, p2)


def ang(v):
    return np.arctan2(v[..., 1], v[..., 0])


def wrap(a):
    return (a + np.pi) % (2 * np.pi) - np.pi


XARM = """
name: xarm_gripper
units: {length: m, angle: rad}
links:
  - name: base
    frames:
      - {name: inner_pivot, xyz: [0.02, 0.074098, 0]}
  - name: outer_knuckle
  - name: finger
    frames:
      - {name: finger_anchor, xyz: [-0.015, 0.015, 0]}
      - {name: pad, xyz: [-0.024003, 0.032, 0]}
  - name: inner_knuckle
    frames:
      - {name: knuckle_anchor, xyz: [0.035465, 0.042039, 0]}
joints:
  - {name: driver, type: revolute, parent: base, child: outer_knuckle,
     origin: {xyz: [0.035, 0.059098, 0]}, limits: [0, 0.85], home: 0}
  - {name: finger_joint, type: revolute, parent: outer_knuckle, child: finger, axis: [0, 0, -1],
     origin: {xyz: [0.035465, 0.042039, 0]}, limits: [0, 0.85], home: 0}
  - {name: inner_knuckle_joint, type: revolute, parent: inner_pivot, child: inner_knuckle,
     limits: [0, 0.85], home: 0}
cuts:
  - {name: pin, frames: [finger_anchor, knuckle_anchor], mask: [x, y]}
independent: [driver]
end_effector: pad
"""


def xarm_closed_form(qv):
    q = np.repeat(np.asarray(qv, float).reshape(-1, 1), 3, axis=1)
    return q  # parallelogram: finger and inner knuckle turn with the driver


ROBOTIQ = """
name: robotiq_fourbar
units: {length: m, angle: rad}
links:
  - name: base
    frames:
      - {name: spring_pivot, xyz: [0.0132, 0.0609, 0]}
  - name: driver
    frames:
      - {name: coupler_anchor, xyz: [0.0375989, 0.043496, 0]}
  - name: spring_link
  - name: follower
    frames:
      - {name: follower_anchor, xyz: [0.018, -0.0065, 0]}
      - {name: pad, xyz: [-0.0009, -0.01245, 0]}
joints:
  - {name: driver_joint, type: revolute, parent: base, child: driver,
     origin: {xyz: [0.0306011, 0.054904, 0]}, limits: [0, 0.8], home: 0}
  - {name: spring_link_joint, type: revolute, parent: spring_pivot, child: spring_link,
     limits: [-0.29670597283, 0.8], home: 0}
  - {name: follower_joint, type: revolute, parent: spring_link, child: follower,
     origin: {xyz: [0.037, 0.044, 0]}, limits: [-0.872664, 0.872664], home: 0}
cuts:
  - {name: pin, frames: [coupler_anchor, follower_anchor], mask: [x, y]}
independent: [driver_joint]
end_effector: pad
"""


def robotiq_closed_form(qv):
    th = np.asarray(qv, float).reshape(-1)
    D0, S0 = np.array([0.0306011, 0.054904]), np.array([0.0132, 0.0609])
    c, s, f = np.array([0.0375989, 0.043496]), np.array([0.037, 0.044]), np.array([0.018, -0.0065])
    C = D0 + np.einsum("mij,j->mi", _rot(th), c)
    S = np.broadcast_to(S0, C.shape)
    J = circle_meet(S, np.linalg.norm(s), C, np.linalg.norm(f), np.sign(cross2(s, f)))
    alpha = wrap(ang(J - S0) - ang(s))
    beta = wrap(ang(C - J) - ang(f) - alpha)
    return np.column_stack([th, alpha, beta])


CASSIE = """
name: cassie_leg
units: {length: m, angle: deg}
links:
  - name: pelvis
  - name: thigh
    frames:
      - {name: rod_root, xyz: [0, 0.05, 0]}
  - name: shin
  - name: tarsus
    frames:
      - {name: heel, xyz: [-0.03, 0.06, 0]}
      - {name: toe, xyz: [0.408, 0, 0]}
  - name: rod
    frames:
      - {name: rod_end, xyz: [0.5012, 0, 0]}
joints:
  - {name: hip_pitch, type: revolute, parent: pelvis, child: thigh, limits: [-50, 80], home: 0}
  - {name: knee, type: revolute, parent: thigh, child: shin, origin: {xyz: [0.12, 0, 0]},
     limits: [-40, 20], home: 0}
  - {name: tarsus_joint, type: revolute, parent: shin, child: tarsus,
     origin: {xyz: [0.4348, 0, 0]}, limits: [-160, 160], home: 10}
  - {name: rod_joint, type: revolute, parent: rod_root, child: rod, limits: [-90, 90], home: 0}
cuts:
  - {name: heel_pin, frames: [rod_end, heel], mask: [x, y]}
independent: [hip_pitch, knee]
end_effector: toe
"""

CASSIE_ROD, CASSIE_HEEL = 0.5012, np.array([-0.03, 0.06])


def cassie_closed_form(qv, sign):
    qv = np.atleast_2d(np.asarray(qv, float))
    kn = qv[:, 1]
    T = np.array([0.12, 0.0]) + np.einsum("mij,j->mi", _rot(kn), [0.4348, 0.0])
    R0 = np.broadcast_to([0.0, 0.05], T.shape)
    H = circle_meet(R0, CASSIE_ROD, T, np.linalg.norm(CASSIE_HEEL), sign)
    tar = wrap(ang(H - T) - ang(CASSIE_HEEL) - kn)
    rod = wrap(ang(H - R0))
    return np.column_stack([qv[:, 0], kn, tar, rod])


SLIDER = """
name: slider_crank
units: {length: m, angle: deg}
links:
  - name: ground
  - name: crank
  - name: rod
    frames:
      - {name: rod_end, xyz: [0.2, 0, 0]}
  - name: slider
    frames:
      - {name: slider_pin, xyz: [0, 0, 0]}
joints:
  - {name: crank_joint, type: revolute, parent: ground, child: crank, home: 30}
  - {name: rod_joint, type: revolute, parent: crank, child: rod, origin: {xyz: [0.05, 0, 0]},
     home: -30}
  - {name: slide, type: prismatic, parent: ground, child: slider, axis: [1, 0, 0],
     origin: {xyz: [0, 0.01, 0]}, limits: [0.14, 0.26], home: 0.24}
cuts:
  - {name: wrist_pin, frames: [rod_end, slider_pin], mask: [x, y]}
independent: [crank_joint]
end_effector: slider_pin
"""


def slider_closed_form(qv):
    th = np.asarray(qv, float).reshape(-1)
    r, rod, e = 0.05, 0.2, 0.01
    x = r * np.cos(th) + np.sqrt(rod**2 - (r * np.sin(th) - e) ** 2)
    phi = np.arctan2(e - r * np.sin(th), x - r * np.cos(th))
    return np.column_stack([th, wrap(phi - th), x])


WATT = """
name: watt_six_bar
units: {length: m, angle: deg}
links:
  - name: ground
    frames:
      - {name: O4, xyz: [0.4, 0, 0]}
      - {name: O6, xyz: [0.75, 0.05, 0]}
  - name: crank
  - name: coupler1
    frames:
      - {name: B1, xyz: [0.35, 0, 0]}
  - name: rocker
    frames:
      - {name: B2, xyz: [0.2, 0, 0]}
      - {name: C, xyz: [0.114907, 0.096418, 0]}
  - name: coupler2
    frames:
      - {name: D1, xyz: [0.3, 0, 0]}
  - name: output
    frames:
      - {name: D2, xyz: [0.25, 0, 0]}
joints:
  - {name: crank_joint, type: revolute, parent: ground, child: crank, home: 60}
  - {name: coupler1_joint, type: revolute, parent: crank, child: coupler1,
     origin: {xyz: [0.1, 0, 0]}, home: -40}
  - {name: rocker_joint, type: revolute, parent: O4, child: rocker, home: 80}
  - {name: coupler2_joint, type: revolute, parent: C, child: coupler2, home: -60}
  - {name: output_joint, type: revolute, parent: O6, child: output, home: 120}
cuts:
  - {name: pin_B, frames: [B1, B2], mask: [x, y]}
  - {name: pin_D, frames: [D1, D2], mask: [x, y]}
independent: [crank_joint]
end_effector: D1
"""


def watt_closed_form(qv, s1, s2):
    th = np.asarray(qv, float).reshape(-1)
    O4, O6 = np.array([0.4, 0.0]), np.array([0.75, 0.05])
    A = np.column_stack([0.1 * np.cos(th), 0.1 * np.sin(th)])
    B = circle_meet(A, 0.35, np.broadcast_to(O4, A.shape), 0.2, s1)
    rk = ang(B - O4)
    c_local = np.array([0.114907, 0.096418])
    C = O4 + np.einsum("mij,j->mi", _rot(rk), c_local)
    D = circle_meet(C, 0.3, np.broadcast_to(O6, C.shape), 0.25, s2)
    return np.column_stack([th, wrap(ang(B - A) - th), wrap(rk),
                            wrap(ang(D - C) - rk), wrap(ang(D - O6))])
