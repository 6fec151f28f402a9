/**
 * @file servo_sim.h
 * @brief Test helper: an ideal eye-in-hand camera looking at a fixed point, moved by the integrated
 *        velocity of VisualServoControl (used by the gtest and the convergence benchmark).
 */
#ifndef COOPERATION_PKG_TEST_SERVO_SIM_H
#define COOPERATION_PKG_TEST_SERVO_SIM_H

#include <vector>

#include "cooperation_pkg/visual_servo_control.h"

namespace cooperation_pkg
{
namespace test
{
/** Desired fruit position in the hand camera for robot.yaml: 13 cm ahead, 1.5 cm above the axis. */
inline vpTranslationVector desiredPoint()
{
  return vpTranslationVector(0.0, -0.015, 0.13);
}

struct SimResult
{
  int iterations = 0;           ///< control moves made
  bool converged = false;
  std::vector<double> errors;   ///< error at the target before each move and at the end [m]
};

/**
 * Runs the loop: error check, control law, camera displacement exp(v dt), until the error is
 * below threshold or max_iterations moves. apply_rotation=false moves the camera by the translation
 * only (the SCARA arm); true applies the full twist (an ideal 6-DOF camera).
 */
inline SimResult simulate(VisualServoControl &law, vpTranslationVector point_in_camera, double dt, double threshold,
                          int max_iterations, bool apply_rotation)
{
  SimResult r;
  while (true)
  {
    if (!(point_in_camera[2] > 0.0))
    {
      return r;  // passed behind the camera: diverged
    }
    const PointFeature cur = PointFeature::fromPoint(point_in_camera);
    const double e = law.errorAtTarget(cur);
    r.errors.push_back(e);
    if (e < threshold)
    {
      r.converged = true;
      return r;
    }
    if (r.iterations >= max_iterations)
    {
      return r;
    }
    vpColVector v = law.computeControlLaw(cur);
    if (!apply_rotation)
    {
      v = VisualServoControl::dropRotation(v);
    }
    const vpHomogeneousMatrix c_M_cnext = VisualServoControl::integrate(v, dt);
    point_in_camera = c_M_cnext.inverse() * point_in_camera;
    ++r.iterations;
  }
}

}  // namespace test
}  // namespace cooperation_pkg

#endif  // COOPERATION_PKG_TEST_SERVO_SIM_H
