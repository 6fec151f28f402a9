/**
 * @file servo_sim.h
 * @brief Test helper: an ideal eye-in-hand camera looking at a fixed point, moved by the integrated
 *        velocity of VisualServoControl (used by the gtest and the convergence benchmark).
 */
#ifndef COOPERATION_PKG_TEST_SERVO_SIM_H
#define COOPERATION_PKG_TEST_SERVO_SIM_H

#include <algorithm>
#include <cmath>
#include <random>
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


/** Limits of one Cartesian axis of the simulated tool [m/s, m/s^2]. */
struct AxisLimits
{
  double vmax;
  double amax;
};

/**
 * The tool (and the rigidly attached camera) of a translating arm, per axis of the camera frame: each
 * axis runs a time-optimal profile to its target within its speed and acceleration limits, and a new
 * target while it moves is taken from the current position and velocity (braking first if it must),
 * as harvest_sim's controller does with a new move_robot goal. Limits of the cutting arm at the tool
 * (robot.yaml, approximately): optical x and z horizontal (boom/forearm, ~0.3 m/s, 0.9 m/s^2),
 * optical y vertical (lift, 0.1 m/s, 0.3 m/s^2).
 */
class SimArm
{
public:
  SimArm()
  {
    limits_[0] = { 0.3, 0.9 };
    limits_[1] = { 0.1, 0.3 };
    limits_[2] = { 0.3, 0.9 };
    for (int i = 0; i < 3; ++i)
    {
      p_[i] = v_[i] = target_[i] = 0.0;
    }
  }
  void setTarget(const vpTranslationVector &target)
  {
    for (int i = 0; i < 3; ++i)
    {
      target_[i] = target[i];
    }
  }
  vpTranslationVector position() const { return vpTranslationVector(p_[0], p_[1], p_[2]); }
  bool atRest() const
  {
    for (int i = 0; i < 3; ++i)
    {
      if (p_[i] != target_[i] || v_[i] != 0.0)
      {
        return false;
      }
    }
    return true;
  }
  /** Advances the arm by dt seconds (semi-implicit integration in steps of at most 0.5 ms). */
  void advance(double dt)
  {
    const int n = std::max(1, static_cast<int>(std::ceil(dt / 5e-4)));
    const double h = dt / n;
    for (int k = 0; k < n; ++k)
    {
      for (int i = 0; i < 3; ++i)
      {
        const double d = target_[i] - p_[i];
        const double a = limits_[i].amax;
        if (std::fabs(d) < 1e-6 && std::fabs(v_[i]) < 2.0 * a * h)
        {
          p_[i] = target_[i];
          v_[i] = 0.0;
          continue;
        }
        // fastest speed from which the axis still stops at the target
        const double v_des = std::copysign(std::min(limits_[i].vmax, std::sqrt(2.0 * a * std::fabs(d))), d);
        v_[i] += std::max(-a * h, std::min(a * h, v_des - v_[i]));
        p_[i] += v_[i] * h;
      }
    }
  }

private:
  AxisLimits limits_[3];
  double p_[3];
  double v_[3];
  double target_[3];
};

/** Timing and noise of a simulated servo run in (simulated) time. */
struct TimedSimConfig
{
  ServoMode mode = ServoMode::STEP;
  double gain = 0.5;              ///< lambda [1/s] of the law the caller builds (simulateTimed uses the law)
  double horizon = 1.0;           ///< dt (STEP) or the short horizon (CONTINUOUS) [s]
  double threshold = 0.002;       ///< stop criterion at the target [m]
  int max_iterations = 15;        ///< control commands before giving up
  double max_step = 0.30;         ///< [m]
  double camera_period = 0.2;     ///< free-running hand camera (5 Hz); 0 = triggered, a frame at each request
  double latency = 0.05;          ///< image -> feature -> kinematics -> move command [s]
  double poll_period = 1.0 / 60;  ///< motion_server notices the end of a move at its next poll [s]
  vpTranslationVector target_bias;  ///< constant error of the target estimate (camera axes) [m]
  double target_noise = 0.0;      ///< per-image error of the target estimate, uniform in +-this per axis [m]
  unsigned seed = 1;
  double time_limit = 60.0;       ///< [s]
};

struct TimedSimResult
{
  bool converged = false;
  int iterations = 0;               ///< control commands sent
  int replaced = 0;                 ///< commands sent while the arm was still moving (CONTINUOUS)
  double time = 0.0;                ///< from the first request to the arm at rest after the stop [s]
  double final_true_error = 0.0;    ///< |tool - goal| at the end, from the true fruit position [m]
  std::vector<double> errors;       ///< error at the target seen at each image [m]
};

/**
 * The visual_servo node's loop in simulated time, for both modes. Per image: the feature (x, y) is the
 * true projection of the fruit, its depth Z comes from the target estimate (true point + bias + noise),
 * as the node takes it from the goal's target through tf; stop when errorAtTarget < threshold (then the
 * arm finishes its last command); otherwise v = law(feature), the tool is sent to its position at the
 * image time plus toolStep(v, horizon). STEP waits for the arm to stop before it asks for the next image;
 * CONTINUOUS asks at once and the next command replaces the running one.
 */
inline TimedSimResult simulateTimed(VisualServoControl &law, const vpTranslationVector &start_point_in_camera,
                                    const TimedSimConfig &c)
{
  TimedSimResult r;
  std::mt19937 rng(c.seed);
  std::uniform_real_distribution<double> noise(-c.target_noise, c.target_noise);
  SimArm arm;
  const vpTranslationVector fruit = start_point_in_camera;  // camera axes, origin at the camera's start
  const vpTranslationVector goal_camera = fruit - law.desired().point();
  double t = 0.0;
  auto advance_to = [&](double until) {
    if (until > t)
    {
      arm.advance(until - t);
      t = until;
    }
  };
  auto next_frame = [&](double request) {
    return c.camera_period > 0.0 ? std::ceil(request / c.camera_period - 1e-9) * c.camera_period : request;
  };
  auto settle = [&]() {
    while (!arm.atRest() && t < c.time_limit)
    {
      advance_to(t + c.poll_period);
    }
  };
  double request = 0.0;
  while (t < c.time_limit)
  {
    advance_to(next_frame(request));
    const vpTranslationVector cam = arm.position();
    vpTranslationVector estimate = fruit + c.target_bias;
    if (c.target_noise > 0.0)
    {
      estimate = estimate + vpTranslationVector(noise(rng), noise(rng), noise(rng));
    }
    const vpTranslationVector seen = fruit - cam;
    const double Z = (estimate - cam)[2];
    if (!(seen[2] > 0.0) || !(Z > 0.0))
    {
      break;  // passed the fruit: diverged
    }
    const PointFeature current(seen[0] / seen[2], seen[1] / seen[2], Z);
    const double e = law.errorAtTarget(current);
    r.errors.push_back(e);
    if (e < c.threshold)
    {
      settle();
      r.converged = true;
      break;
    }
    if (r.iterations >= c.max_iterations)
    {
      break;
    }
    const ToolStep step = VisualServoControl::toolStep(law.computeControlLaw(current), c.horizon, c.max_step);
    advance_to(t + c.latency);
    if (!arm.atRest())
    {
      ++r.replaced;
    }
    arm.setTarget(cam + step.translation);
    ++r.iterations;
    if (c.mode == ServoMode::STEP)
    {
      settle();  // move_robot's result comes at the poll that sees the arm at rest
    }
    request = t;
  }
  r.time = t;
  r.final_true_error = (arm.position() - goal_camera).frobeniusNorm();
  return r;
}

}  // namespace test
}  // namespace cooperation_pkg

#endif  // COOPERATION_PKG_TEST_SERVO_SIM_H
