"""The MCAP topic names mechkin writes, in a module of their own so that the Foxglove layouts
(:mod:`mechkin.io.foxglove_layout`) name them without loading the MCAP and protobuf code of
:mod:`mechkin.io.mcap_out`, which re-exports them.
"""

from __future__ import annotations

TOPIC_TF = "/tf"
TOPIC_SCENE = "/scene"
TOPIC_JOINTS = "/joint_states"
TOPIC_STATE = "/mechkin/state"
TOPIC_ROBOT = "/robot_description"
TOPIC_TARGETS = "/mechkin/targets"
