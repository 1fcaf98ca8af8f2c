"""mechkin: kinematics analysis of open, closed and complex-chain robot mechanisms.

Frames: ``T_a_b`` is the pose of frame b expressed in frame a (maps b-coordinates to a), so
``T_a_c = T_a_b @ T_b_c``. Units are SI inside (m, rad, s, N m).
"""

__version__ = "0.1.0"
