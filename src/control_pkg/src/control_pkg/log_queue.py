"""rospy's log lines written by a background thread, so that a log line never delays a goal.

rospy sends every `rospy.loginfo` of a node through the Python logger `rosout` to its handlers
(the console, /rosout) and, propagated, to the root logger's log file, all in the caller's
thread: about 0.5 ms a line on a quiet 2-core machine and 1-2 ms in a running mission. The
executive logs a line or two between one action's result and the next goal, so half of its
overhead per action state was writing log lines (bench_mission's executive overhead).

`defer(logger_name)` puts a logging.handlers.QueueHandler in place of that logger's handlers;
a QueueListener thread hands each record to them and to the root logger's handlers (the logger
no longer propagates, so nothing is written twice). The caller only builds the record: its time
(`created`), level, file and line are the caller's, as before; the text is formatted then (so a
later change of an argument does not change the line). Records keep their order. `stop()`
writes what is queued and restores the handlers; it is registered with atexit, and the node
also calls it on rospy shutdown.
"""
import atexit
import logging
import logging.handlers
import threading

try:
    import queue
except ImportError:  # pragma: no cover - Python 2
    import Queue as queue


class DeferredLog(object):
    """The handlers of one logger (and the root logger's, which it propagated to), run by a
    QueueListener thread. Use `defer()`."""

    def __init__(self, logger_name):
        self.logger = logging.getLogger(logger_name)
        root = logging.getLogger()
        self._handlers = list(self.logger.handlers)
        self._propagate = self.logger.propagate
        targets = list(self._handlers)
        if self._propagate and self.logger is not root:
            targets += [h for h in root.handlers if h not in targets]
        self._queue = queue.Queue(-1)
        self.handler = logging.handlers.QueueHandler(self._queue)
        self.listener = logging.handlers.QueueListener(self._queue, *targets,
                                                       respect_handler_level=True)
        self._lock = threading.Lock()
        self._running = False

    def start(self):
        with self._lock:
            if self._running:
                return self
            for h in self._handlers:
                self.logger.removeHandler(h)
            self.logger.addHandler(self.handler)
            self.logger.propagate = False
            self.listener.start()
            self._running = True
        return self

    def stop(self):
        """Write every queued record, then give the logger its own handlers back."""
        with self._lock:
            if not self._running:
                return
            self._running = False
            self.logger.removeHandler(self.handler)
            for h in self._handlers:
                self.logger.addHandler(h)
            self.logger.propagate = self._propagate
            self.listener.stop()


def defer(logger_name='rosout'):
    """Start writing `logger_name`'s records (rospy's: 'rosout') in a background thread; call
    after rospy.init_node, which sets up the handlers. Returns the DeferredLog (stop() it)."""
    deferred = DeferredLog(logger_name).start()
    atexit.register(deferred.stop)
    return deferred
