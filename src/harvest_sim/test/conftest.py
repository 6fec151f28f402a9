"""Makes the harvest_sim test helpers importable (sim_fixtures) without a catkin build."""
import os
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
