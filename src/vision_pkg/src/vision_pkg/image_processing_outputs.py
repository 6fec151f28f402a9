"""Diagnostics and visual outputs of the image_processing node (ROS glue, a mixin of
ImageProcessingNode): input-rate diagnostics on /diagnostics, the annotated right image on
detections/image and the markers on detections/markers (built by vision_pkg.markers).

The node provides self.bridge, self.image_pub and self.marker_pub.
"""
import rospy
import diagnostic_updater

from vision_pkg import annotate, names
from vision_pkg.markers import tomato_markers

#: accepted input-rate band for diagnostics, as a fraction of the expected rate
RATE_TOLERANCE = 0.5


class NoRateCheck(object):
    """Stands in for a frequency diagnostic of an input that comes on demand."""

    def tick(self):
        pass


class ImageProcessingOutputs(object):
    """Diagnostics set-up and the visual outputs of a SPATIAL_POSITIONING result."""

    def _setup_diagnostics(self):
        self.updater = diagnostic_updater.Updater()
        self.updater.setHardwareID('image_processing')
        self._freq = {}
        for topic, rate_param in ((names.RIGHT_RECT_COLOR, '~expected_rate'),
                                  (names.POINTS2, '~expected_rate'),
                                  (names.HAND_IMAGE, '~hand_expected_rate')):
            rate = float(rospy.get_param(rate_param, 10.0))
            if rate <= 0.0:          # triggered camera: frames come on demand, no rate to check
                self._freq[topic] = NoRateCheck()
                continue
            bounds = {'min': rate * (1.0 - RATE_TOLERANCE), 'max': rate * (1.0 + RATE_TOLERANCE)}
            self._freq[topic] = diagnostic_updater.HeaderlessTopicDiagnostic(
                topic, self.updater, diagnostic_updater.FrequencyStatusParam(bounds, 0.1, 10))
        self._diag_timer = rospy.Timer(rospy.Duration(1.0), lambda _e: self.updater.update())

    def _publish_visuals(self, array, detections, image_msg, frame):
        if self.image_pub.get_num_connections() > 0:
            bgr = self.bridge.imgmsg_to_cv2(image_msg, 'bgr8')
            drawn = annotate.annotate(bgr, [(d, t.pick_order)
                                            for d, t in zip(detections, array.tomatoes)])
            out = self.bridge.cv2_to_imgmsg(drawn, 'bgr8')
            out.header = image_msg.header
            self.image_pub.publish(out)
        self.marker_pub.publish(tomato_markers(array, frame))
