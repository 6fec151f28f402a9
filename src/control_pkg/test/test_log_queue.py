"""control_pkg.log_queue: log records written by a background thread, none lost, in order,
with the caller's time, file and line."""
import logging
import threading

from control_pkg import log_queue


class Collect(logging.Handler):
    def __init__(self):
        logging.Handler.__init__(self)
        self.records = []
        self.threads = []          # the thread that emitted each record
        self.done = threading.Event()

    def emit(self, record):
        self.records.append(record)
        self.threads.append(threading.current_thread().name)
        if record.getMessage() == 'last':
            self.done.set()


def _logger(name):
    logger = logging.getLogger(name)
    logger.handlers = []
    logger.setLevel(logging.DEBUG)
    logger.propagate = False
    own = Collect()
    logger.addHandler(own)
    return logger, own


def _warn(logger, text):
    logger.warning(text)       # one source line for a direct and a deferred record


def test_records_arrive_in_order_from_another_thread_with_the_callers_line():
    logger, own = _logger('test_log_queue.order')
    _warn(logger, 'direct')
    deferred = log_queue.DeferredLog('test_log_queue.order').start()
    try:
        for i in range(50):
            logger.info('line %d of %s', i, 'fifty')
        _warn(logger, 'last')
        own.done.wait(10.0)
    finally:
        deferred.stop()
    texts = [r.getMessage() for r in own.records]
    assert texts == ['direct'] + ['line %d of fifty' % i for i in range(50)] + ['last']
    here = threading.current_thread().name
    assert own.threads[0] == here and here not in own.threads[1:]
    direct, last = own.records[0], own.records[-1]
    # made in the caller's thread: the same caller as a record written directly (whatever
    # logger class finds it: rospy installs its own), the caller's thread, WARNING kept
    assert (last.pathname, last.lineno, last.funcName) == \
        (direct.pathname, direct.lineno, direct.funcName)
    assert last.threadName == here
    assert last.levelno == logging.WARNING
    times = [r.created for r in own.records]
    assert times == sorted(times)


def test_stop_writes_what_is_queued_and_restores_the_handlers():
    logger, own = _logger('test_log_queue.stop')
    deferred = log_queue.DeferredLog('test_log_queue.stop').start()
    for i in range(200):
        logger.debug('queued %d', i)
    deferred.stop()
    assert [r.getMessage() for r in own.records] == ['queued %d' % i for i in range(200)]
    assert logger.handlers == [own]
    logger.info('direct')
    assert own.records[-1].getMessage() == 'direct'
    assert own.threads[-1] == threading.current_thread().name


def test_a_propagating_logger_reaches_the_root_handlers_once():
    name = 'test_log_queue.propagate'
    logger, own = _logger(name)
    logger.propagate = True
    root = logging.getLogger()
    root_own = Collect()
    root.addHandler(root_own)
    try:
        deferred = log_queue.DeferredLog(name).start()
        assert logger.propagate is False
        logger.error('to both')
        deferred.stop()
        assert logger.propagate is True
    finally:
        root.removeHandler(root_own)
    assert [r.getMessage() for r in own.records] == ['to both']
    assert [r.getMessage() for r in root_own.records] == ['to both']


def test_an_exception_keeps_its_traceback_text():
    logger, own = _logger('test_log_queue.exc')
    deferred = log_queue.DeferredLog('test_log_queue.exc').start()
    try:
        raise ValueError('bad goal')
    except ValueError:
        logger.exception('it failed')
    deferred.stop()
    (record, ) = own.records
    assert 'ValueError: bad goal' in record.getMessage()
