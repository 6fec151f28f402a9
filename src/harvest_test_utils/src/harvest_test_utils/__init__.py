"""Test helpers shared by two or more packages of the workspace (no ROS master needed).

- harvest_test_utils.net: free loopback ports, polling a condition with a deadline
- harvest_test_utils.farm: network_pkg's farm server as a child process
- harvest_test_utils.strict_deps: the pytest plugin of HARVEST_STRICT_DEPS=1
"""
