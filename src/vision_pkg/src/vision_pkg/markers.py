"""rviz markers of a SPATIAL_POSITIONING result (detections/markers), rospy-free: a sphere per
located fruit coloured by ripeness stage and a text with its picking order (or its score)."""
import math

from visualization_msgs.msg import Marker, MarkerArray

from vision_pkg import annotate


def tomato_markers(array, frame):
    """MarkerArray for a TomatoArray whose pick points are in `frame`: DELETEALL first, then
    per fruit with a 3D point a sphere (ns 'tomatoes') and a text (ns 'pick_order')."""
    markers = MarkerArray()
    clear = Marker()
    clear.action = Marker.DELETEALL
    markers.markers.append(clear)
    for tomato in array.tomatoes:
        if not math.isfinite(tomato.pick_point.point.x):
            continue
        r, g, b = annotate.STAGE_RGB[tomato.ripeness_stage]
        sphere = Marker()
        sphere.header.frame_id = frame
        sphere.header.stamp = array.header.stamp
        sphere.ns = 'tomatoes'
        sphere.id = tomato.id
        sphere.type = Marker.SPHERE
        sphere.action = Marker.ADD
        sphere.pose.position = tomato.pick_point.point
        sphere.pose.orientation.w = 1.0
        sphere.scale.x = sphere.scale.y = sphere.scale.z = 2.0 * max(tomato.radius, 0.005)
        sphere.color.r, sphere.color.g, sphere.color.b, sphere.color.a = r, g, b, 0.9
        markers.markers.append(sphere)
        text = Marker()
        text.header = sphere.header
        text.ns = 'pick_order'
        text.id = tomato.id
        text.type = Marker.TEXT_VIEW_FACING
        text.action = Marker.ADD
        text.pose.position.x = tomato.pick_point.point.x
        text.pose.position.y = tomato.pick_point.point.y
        text.pose.position.z = tomato.pick_point.point.z + tomato.radius + 0.02
        text.pose.orientation.w = 1.0
        text.scale.z = 0.03
        text.color.r = text.color.g = text.color.b = text.color.a = 1.0
        text.text = ('#%d' % (tomato.pick_order + 1)) if tomato.pickable else \
            '%.2f' % tomato.ripeness_score
        markers.markers.append(text)
    return markers
