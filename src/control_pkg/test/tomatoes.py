"""Tomato messages for the executive's pure tests (imported by the test modules beside it)."""
from harvest_msgs.msg import Tomato


def tomato(tid, xyz, radius, frame='base_link', pickable=True, order=0):
    t = Tomato()
    t.id = tid
    t.pick_point.header.frame_id = frame
    t.pick_point.point.x, t.pick_point.point.y, t.pick_point.point.z = xyz
    t.radius = radius
    t.pickable = pickable
    t.pick_order = order
    return t


def xyz(point_stamped):
    p = point_stamped.point
    return (p.x, p.y, p.z)
