"""Image panel (the paper's image module): left rectified, hand camera and the annotated detection image.

Images are converted to QImage in the subscriber thread (at most `max_rate` per second and view),
then handed to the GUI thread through a queued Signal.
"""
import rospy
from python_qt_binding.QtCore import QRectF, Qt, QTimer, Signal
from python_qt_binding.QtGui import QColor, QFont, QImage, QPainter
from python_qt_binding.QtWidgets import QComboBox, QGridLayout, QVBoxLayout, QWidget
from sensor_msgs.msg import Image

from visualization_pkg.dashboard import image_convert
from visualization_pkg.dashboard.qt_common import Panel, ros_now

DEFAULT_TOPICS = [('Left rectified', 'stereo/left/image_rect_color'), ('Hand camera', 'hand_eye/image_raw'),
                  ('Detections', 'detections/image')]


class ImageView(QWidget):
    """Paints one image scaled to fit, with its title, size, rate and age."""

    def __init__(self, title, parent=None):
        QWidget.__init__(self, parent)
        self.title = title
        self.image = None
        self.stamp = None
        self.received = None
        self.frames = 0
        self.error = ''
        self.setMinimumSize(160, 120)

    def set_image(self, image, received):
        self.image = image
        self.received = received
        self.frames += 1
        self.error = ''
        self.update()

    def paintEvent(self, _event):
        p = QPainter(self)
        p.fillRect(self.rect(), QColor('#263238'))
        if self.image is not None and not self.image.isNull():
            img = self.image
            scale = min(self.width() / float(img.width()), self.height() / float(img.height()))
            w, h = img.width() * scale, img.height() * scale
            target = QRectF((self.width() - w) / 2.0, (self.height() - h) / 2.0, w, h)
            p.setRenderHint(QPainter.SmoothPixmapTransform)
            p.drawImage(target, img)
        font = QFont()
        font.setPointSizeF(8.5)
        font.setBold(True)
        p.setFont(font)
        band = QRectF(0, 0, self.width(), 18)
        p.fillRect(band, QColor(0, 0, 0, 150))
        p.setPen(QColor('#ffffff'))
        p.drawText(band.adjusted(6, 0, -6, 0), Qt.AlignVCenter | Qt.AlignLeft, self.title)
        if self.image is not None:
            age = ros_now() - self.received if self.received is not None else 0.0
            info = '%.1f s old' % age if age > 2.0 else '%dx%d' % (self.image.width(), self.image.height())
            p.setPen(QColor('#ffcc80') if age > 2.0 else QColor('#b0bec5'))
            p.drawText(band.adjusted(6, 0, -6, 0), Qt.AlignVCenter | Qt.AlignRight, info)
        if self.image is None:
            p.setPen(QColor('#90a4ae'))
            p.drawText(QRectF(self.rect()), Qt.AlignCenter, self.error or 'no image yet')
        p.end()


class ImagePanel(Panel):
    title = 'Images'
    image_received = Signal(int, object, float)

    def __init__(self, topics=None, max_rate=8.0, max_width=960, columns=3, parent=None):
        Panel.__init__(self, parent)
        self.topics = [tuple(t) for t in (topics or DEFAULT_TOPICS)]
        self.max_rate = float(max_rate)
        self.max_width = int(max_width)
        self.views = []
        self.combos = []
        self._image_subs = [None] * len(self.topics)
        self._last = [0.0] * len(self.topics)
        grid = QGridLayout(self)
        grid.setContentsMargins(2, 2, 2, 2)
        grid.setSpacing(4)
        for i, (title, topic) in enumerate(self.topics):
            box = QWidget()
            v = QVBoxLayout(box)
            v.setContentsMargins(0, 0, 0, 0)
            v.setSpacing(2)
            view = ImageView(title)
            combo = QComboBox()
            combo.setEditable(True)
            combo.addItem(topic)
            combo.setToolTip('sensor_msgs/Image topic of this view')
            combo.setSizeAdjustPolicy(QComboBox.AdjustToMinimumContentsLengthWithIcon)
            combo.setMinimumContentsLength(10)
            combo.activated.connect(lambda _i, i=i: self._topic_changed(i))
            combo.lineEdit().editingFinished.connect(lambda i=i: self._topic_changed(i))
            v.addWidget(view, 1)
            v.addWidget(combo)
            grid.addWidget(box, i // columns, i % columns)
            self.views.append(view)
            self.combos.append(combo)
        self.image_received.connect(self._on_image, Qt.QueuedConnection)
        self._timer = QTimer(self)
        self._timer.setInterval(1000)
        self._timer.timeout.connect(self._tick)

    def start(self):
        Panel.start(self)
        for i in range(len(self.views)):
            self._subscribe(i)
        self._timer.start()

    def shutdown(self):
        self._timer.stop()
        for i, sub in enumerate(self._image_subs):
            if sub is not None:
                sub.unregister()
                self._image_subs[i] = None
        Panel.shutdown(self)

    def _subscribe(self, i):
        if self._image_subs[i] is not None:
            self._image_subs[i].unregister()
        topic = self.combos[i].currentText().strip()
        if not topic:
            self._image_subs[i] = None
            return
        self._image_subs[i] = rospy.Subscriber(topic, Image, self._callback, callback_args=i, queue_size=1,
                                               buff_size=2 ** 24)

    def _topic_changed(self, i):
        if self._started:
            self.views[i].image = None
            self.views[i].update()
            self._subscribe(i)

    def _callback(self, msg, i):
        """Subscriber thread: throttle, convert, hand over through the queued signal."""
        now = ros_now()
        if now - self._last[i] < 1.0 / self.max_rate and now >= self._last[i]:
            return
        self._last[i] = now
        try:
            rgb = image_convert.to_rgb(msg.encoding, msg.height, msg.width, msg.step, msg.data, self.max_width)
        except ValueError as exc:
            self.image_received.emit(i, str(exc), now)
            return
        h, w = rgb.shape[:2]
        image = QImage(rgb.data, w, h, 3 * w, QImage.Format_RGB888).copy()
        self.image_received.emit(i, image, now)

    def _on_image(self, i, image, received):
        if isinstance(image, str):
            self.views[i].error = image
            self.views[i].update()
            return
        self.views[i].set_image(image, received)

    def _tick(self):
        for view in self.views:
            view.update()

    def save_settings(self, s):
        s.set('topics', [c.currentText() for c in self.combos])

    def restore_settings(self, s):
        topics = s.get_list('topics', [])
        for combo, topic in zip(self.combos, topics):
            if topic and topic != combo.currentText():
                combo.setEditText(topic)
                if combo.findText(topic) < 0:
                    combo.addItem(topic)
                combo.setCurrentIndex(combo.findText(topic))
        if self._started:
            for i in range(len(self.combos)):
                self._subscribe(i)
