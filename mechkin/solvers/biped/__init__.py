r"""The hwang2023 biped: closed-form leg kinematics and both legs over a switching sequence.

Owns the walking and skating legs' closed-form IK classes (``leg``, hwang2023 §2-§3: the
shared model in ``leg_model``, one module per IK class, ``leg_known_pose`` §2.2,
``leg_known_position`` §2.3, ``leg_rolling`` §2.4), the
blade's rolling contact as a virtual chain closed by a cut (``rolling_chain``, hwang2023 §2.3)
and both legs over a walk -> skate -> roll sequence (``sequence``).

May import: ``mechkin.model``, ``mechkin.spatial``, ``mechkin.config.schema``,
``mechkin.errors`` and ``mechkin.solvers.result``; never ``tasks``, ``io`` or ``cli``.
"""
