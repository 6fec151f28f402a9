"""The store validates outcome and ripeness codes against its own copy of them (schema.py stays
free of ROS: network_pkg's uploader opens the store without it). The copies must be the message
constants: harvest_msgs/PickRecord OUTCOME_* and Tomato STAGE_*."""
from harvest_msgs.msg import PickRecord, Tomato

from database_pkg import schema


def constants(msg_type, prefix):
    return tuple(sorted(getattr(msg_type, n) for n in dir(msg_type) if n.startswith(prefix)))


def test_outcome_codes_are_the_pick_records():
    assert schema.OUTCOMES == constants(PickRecord, 'OUTCOME_')


def test_ripeness_stages_are_the_tomatos():
    assert schema.RIPENESS_STAGES == constants(Tomato, 'STAGE_')
