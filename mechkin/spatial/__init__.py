"""Pure functions on arrays: rotations, Euler parameters, D-H transforms, SE(3) helpers.

Convention (said once here): ``T_a_b`` (4, 4) is the pose of frame b expressed in frame a; it maps
b-coordinates to a-coordinates, ``p_a = T_a_b @ p_b``, so ``T_a_c = T_a_b @ T_b_c``. ``R_a_b`` is
its rotation, ``p_a_b`` the position of b's origin in a. Quaternions (Euler parameters) are stored
scalar first, ``(e0, e1, e2, e3)``. Batches put the sample axis first: ``Ts (m, 4, 4)``.
"""

from mechkin.spatial.dh import dh_modified, dh_standard
from mechkin.spatial.rotations import (
    euler_vector_from_matrix,
    matrix_from_quat,
    matrix_from_rpy,
    quat_from_matrix,
    rot_axis,
    rot_x,
    rot_y,
    rot_z,
    rpy_from_matrix,
    skew,
)
from mechkin.spatial.transforms import T_from, invert, transform_from_xyz_rpy, translation

__all__ = [
    "quat_from_matrix",
    "matrix_from_quat",
    "rot_x",
    "rot_y",
    "rot_z",
    "rot_axis",
    "matrix_from_rpy",
    "rpy_from_matrix",
    "skew",
    "euler_vector_from_matrix",
    "T_from",
    "invert",
    "translation",
    "transform_from_xyz_rpy",
    "dh_standard",
    "dh_modified",
]
