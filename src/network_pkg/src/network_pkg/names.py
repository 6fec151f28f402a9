"""Topic names of the uploader (relative; launch files wire them).

The uploader publishes the plan topic and control_pkg's executive subscribes to it; neither
package depends on the other, so control_pkg/names.py holds the same name and harvest_bringup's
test_contract_names checks that the two agree.
"""

#: std_msgs/Int32MultiArray, latched: the picking points of today's plan, in visit order
PLAN = 'plan/picking_points'
