"""The SERVO_FEATURE request of the image_processing node (ROS glue, a mixin of
ImageProcessingNode): the hand camera's image and camera_info, the wait for a fresh hand image
(hand_eye/image_trigger) and the ServoFeature of the tomato the visual servo follows. Its
geometry (sphere-centre projection, reference point of the hint) is in image_processing_goals.

The node provides self._cond, self._wait, self._freq, self.bridge, self.hand_detector,
self.hand_trigger, self.tf_buffer, self.tf_timeout and self.fresh_data.
"""
import math

import rospy
import tf2_ros
from cv_bridge import CvBridgeError
from geometry_msgs.msg import PointStamped
from harvest_msgs.msg import ServoFeature

from vision_pkg import names, ordering
from vision_pkg.image_processing_goals import (Aborted, camera_model, servo_reference,
                                               undistorted_centre)


class HandCamera(object):
    """Hand camera input and the servo feature (see module docstring)."""

    _undistorted_centre = staticmethod(undistorted_centre)

    def _on_hand_image(self, msg):
        self._freq[names.HAND_IMAGE].tick()
        with self._cond:
            self._hand_image = msg
            self._cond.notify_all()

    def _on_hand_info(self, msg):
        with self._cond:
            self._hand_info = msg

    def _hand_data(self, goal, since):
        def ready():
            msg = self._hand_image
            if msg is None or self._hand_info is None or msg.header.stamp < since:
                return None
            return msg, self._hand_info
        return self._wait(ready, goal, 'hand camera image on %s with camera_info'
                          % names.HAND_IMAGE, self.hand_trigger)

    def servo_feature(self, hint, state, fresh_from):
        """ServoFeature of the tomato nearest to the hint's projection in the hand camera."""
        since = fresh_from if self.fresh_data else rospy.Time(0)
        image_msg, info = self._hand_data(state, since)
        try:
            bgr = self.bridge.imgmsg_to_cv2(image_msg, 'bgr8')
        except CvBridgeError as exc:
            raise Aborted('cannot convert %s: %s' % (names.HAND_IMAGE, exc))
        k, dist = camera_model(info)
        feature = ServoFeature()
        feature.header = image_msg.header
        detections = self.hand_detector.detect(bgr)
        hint_cam = None
        if hint.header.frame_id:
            values = (hint.point.x, hint.point.y, hint.point.z)
            if not all(math.isfinite(v) for v in values):
                raise Aborted('target_hint has a non-finite coordinate')
            query = PointStamped()
            query.header.frame_id = hint.header.frame_id
            query.header.stamp = image_msg.header.stamp
            query.point = hint.point
            try:
                hint_cam = self.tf_buffer.transform(query, image_msg.header.frame_id,
                                                    rospy.Duration(self.tf_timeout))
            except (tf2_ros.LookupException, tf2_ros.ConnectivityException,
                    tf2_ros.ExtrapolationException) as exc:
                raise Aborted('cannot transform target_hint from %s to %s: %s'
                              % (hint.header.frame_id, image_msg.header.frame_id, exc))
        if not detections:
            return feature
        centres = [self._undistorted_centre(d, k, dist) for d in detections]
        ref, depth = servo_reference(hint_cam.point if hint_cam is not None else None, k, dist)
        if depth is not None:
            feature.depth = depth
        # with a hint the target's centre must lie on the fruit followed (not a neighbour)
        best = ordering.servo_target([c[:2] for c in centres],
                                     [d.radius_px for d in detections], ref,
                                     on_fruit=hint_cam is not None)
        if best is None:
            rospy.logwarn_throttle(2.0, 'image_processing: no fruit in the hand image holds the '
                                   'target\'s projection (%.0f, %.0f); %d others seen'
                                   % (ref[0], ref[1], len(detections)))
            return feature
        u, v, x, y = centres[best]
        feature.found = True
        feature.u, feature.v, feature.x, feature.y = u, v, x, y
        feature.diameter_px = 2.0 * detections[best].radius_px
        return feature
