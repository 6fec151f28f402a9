"""When a simulated camera frame may go out and with which stamp (pure logic, no rospy).

A frame shows the robot at the joint state the camera rendered it from, so it carries that
joint state's time, never the time it is sent: on a loaded machine the camera's joint states
lag, and a frame stamped "now" that still showed the cart at the previous picking point would
pass every freshness check of the robot stack (a scan after a move then located the previous
point's fruit). A frame whose stamp would not be newer than the last one's is not sent: it
would tell nothing new, or, if the view changed meanwhile (the world moved a fruit), two
different pictures would share a stamp and stereo_image_proc's exact sync could pair the left
eye of one with the right eye of the other.

Times are any totally ordered values (rospy.Time, float seconds).
"""


def frame_stamp(now, joint_stamp, last_stamp=None):
    """Stamp of a frame rendered now from the joint state stamped joint_stamp, or None when the
    frame must not be sent. joint_stamp None (no joint state yet: a fixed camera, or a test that
    never moves the robot) stamps the frame with now."""
    stamp = now if joint_stamp is None or joint_stamp > now else joint_stamp
    if last_stamp is not None and not stamp > last_stamp:
        return None
    return stamp


def next_frame_hold(now, expected, period):
    """Where a free-running camera holds the clock after its frame at `now`: the time its
    next frame is due. A periodic rospy.Timer fires next at most one period after the time it
    fired (its Rate starts afresh after a jump), while the event's `expected` time only ever
    adds periods: if the timer started before the clock or the clock once ran on (a dropped
    hold), `expected` stays behind, a hold there lies in the past, and every frame after that
    stopped the clock until sim_clock dropped the hold (10 wall seconds each). So: one period
    after the later of the two."""
    return max(now, expected) + period


#: camera name of the camera_silence fault that silences every camera
ALL_CAMERAS = 'all'
CAMERA_NAMES = ('stereo', 'hand')


class CameraSilence(object):
    """The camera_silence fault of one camera (named by its kind, stereo or hand): while
    silent it publishes nothing and holds no clock, so the simulated clock runs on and the
    silence, counted in ROS time, ends. Times are any totally ordered values."""

    def __init__(self, name):
        self.name = name
        self.until = None

    def applies(self, camera):
        return camera in (self.name, ALL_CAMERAS)

    def set(self, camera, until):
        """A silence of `camera` until `until` (None or a time already past: it ends); True
        when it concerns this camera."""
        if not self.applies(camera):
            return False
        self.until = until
        return True

    def silent(self, now):
        return self.until is not None and now < self.until

    def hold(self, now, until):
        """The clock hold a camera may ask for at `now` when it wants `until`: none while
        silent (a silent camera never stops the clock)."""
        return None if self.silent(now) else until
