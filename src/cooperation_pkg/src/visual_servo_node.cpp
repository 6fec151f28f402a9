/**
 * @file visual_servo_node.cpp
 * @brief Thin main of the `visual_servo` node (see visual_servo_cycle_node.h and README.md).
 */
#include <stdexcept>

#include <ros/ros.h>

#include "cooperation_pkg/visual_servo_cycle_node.h"

int main(int argc, char **argv)
{
  ros::init(argc, argv, "visual_servo");
  ros::NodeHandle nh;
  ros::NodeHandle pnh("~");
  try
  {
    cooperation_pkg::VisualServoCycleNode node(nh, pnh);
    ros::spin();
  }
  catch (const std::invalid_argument &e)
  {
    ROS_FATAL("visual_servo: %s", e.what());
    return 1;
  }
  return 0;
}
