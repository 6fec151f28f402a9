"""The workspace's tools/ scripts (run_demo.py, bench_mission.py, test_summary.py...) as modules,
for the tests of what they compute: they are scripts beside the packages, not a package."""
import importlib.util
import os


def tools_dir():
    """<workspace>/tools, found from this package's source folder (src/harvest_test_utils)."""
    import rospkg
    here = rospkg.RosPack().get_path('harvest_test_utils')
    return os.path.normpath(os.path.join(here, '..', '..', 'tools'))


def load_tool(name):
    """tools/<name>.py loaded as a fresh module named `name`."""
    spec = importlib.util.spec_from_file_location(name, os.path.join(tools_dir(), name + '.py'))
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
