/**
 * @file visual_servo_cycle.cpp
 * @brief The ROS-free part of the visual_servo loop: settings, goal overrides, geometry, stop and lost-target
 *        policy, report texts (see visual_servo_cycle.h).
 */
#include "cooperation_pkg/visual_servo_cycle.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <stdexcept>

namespace cooperation_pkg
{
namespace
{
bool finite(double v)
{
  return std::isfinite(v);
}
}  // namespace

void requireParameter(bool ok, const std::string &what)
{
  if (!ok)
  {
    throw std::invalid_argument("invalid parameter: " + what);
  }
}

void checkSettings(const ServoSettings &s)
{
  requireParameter(finite(s.gain) && s.gain > 0.0, "~gain must be > 0 [1/s]");
  requireParameter(finite(s.dt) && s.dt > 0.0, "~dt must be > 0 [s]");
  requireParameter(finite(s.threshold) && s.threshold > 0.0, "~threshold must be > 0 [m]");
  requireParameter(s.max_iterations > 0, "~max_iterations must be > 0");
  requireParameter(finite(s.peduncle_gap) && s.peduncle_gap >= 0.0, "~peduncle_gap must be >= 0 [m]");
  requireParameter(finite(s.default_radius) && s.default_radius > 0.0, "~default_radius must be > 0 [m]");
  requireParameter(s.max_lost > 0, "~max_lost must be > 0");
  requireParameter(finite(s.max_step) && s.max_step > 0.0, "~max_step must be > 0 [m]");
  requireParameter(finite(s.max_gain_dt) && s.max_gain_dt > 0.0, "~max_gain_dt must be > 0");
  requireParameter(finite(s.continuous_gain) && s.continuous_gain > 0.0, "~continuous_gain must be > 0 [1/s]");
  requireParameter(finite(s.horizon) && s.horizon > 0.0, "~horizon must be > 0 [s]");
  requireParameter(s.continuous_max_iterations > 0, "~continuous_max_iterations must be > 0");
  requireParameter(
      s.adaptive_gain_at_infinity == 0.0 ||
          (s.adaptive_gain_at_infinity > 0.0 && s.adaptive_gain_at_infinity < s.gain && s.adaptive_slope_at_zero > 0.0),
      "adaptive gain needs 0 < ~adaptive_gain_at_infinity < ~gain and ~adaptive_slope_at_zero > 0");
}

const char *holdTimeName(ServoMode mode)
{
  return mode == ServoMode::CONTINUOUS ? "horizon" : "dt";
}

ServoSettings modeSettings(const ServoSettings &configured)
{
  ServoSettings s = configured;
  if (s.mode == ServoMode::CONTINUOUS)
  {
    // From here on gain, dt and max_iterations are those of the mode (the goal's overrides apply to them).
    s.gain = s.continuous_gain;
    s.dt = s.horizon;
    s.max_iterations = s.continuous_max_iterations;
    s.adaptive_gain_at_infinity = 0.0;  // constant gain in continuous mode
  }
  return s;
}

bool goalSettings(const ServoSettings &configured, const ServoGoalRequest &goal, ServoSettings &s, double &radius,
                  std::string &why)
{
  s = modeSettings(configured);
  if (!finite(goal.x) || !finite(goal.y) || !finite(goal.z))
  {
    why = "invalid goal: target point is not finite";
    return false;
  }
  if (goal.frame_id.empty())
  {
    why = "invalid goal: target.header.frame_id is empty";
    return false;
  }
  if (!finite(goal.target_radius) || goal.target_radius < 0.0 || goal.target_radius > 0.2)
  {
    why = "invalid goal: target_radius must be in [0, 0.2] m (0 = default)";
    return false;
  }
  if (!finite(goal.gain) || goal.gain < 0.0)
  {
    why = "invalid goal: gain must be >= 0 (0 = default)";
    return false;
  }
  if (!finite(goal.threshold) || goal.threshold < 0.0)
  {
    why = "invalid goal: threshold must be >= 0 m (0 = default)";
    return false;
  }
  if (goal.max_iterations < 0)
  {
    why = "invalid goal: max_iterations must be >= 0 (0 = default)";
    return false;
  }
  if (goal.gain > 0.0)
  {
    s.gain = goal.gain;
    s.adaptive_gain_at_infinity = 0.0;  // an explicit gain is a constant gain
  }
  if (goal.threshold > 0.0)
  {
    s.threshold = goal.threshold;
  }
  if (goal.max_iterations > 0)
  {
    s.max_iterations = goal.max_iterations;
  }
  if (s.gain * s.dt > s.max_gain_dt)
  {
    char buf[200];
    std::snprintf(buf, sizeof(buf), "invalid goal: gain * %s = %.2f exceeds %.2f (the loop overshoots and diverges)",
                  holdTimeName(s.mode), s.gain * s.dt, s.max_gain_dt);
    why = buf;
    return false;
  }
  radius = goal.target_radius > 0.0 ? goal.target_radius : s.default_radius;
  return true;
}

vpTranslationVector desiredTargetPoint(const vpHomogeneousMatrix &cam_M_tool, const vpRotationMatrix &base_R_tool,
                                       double radius, double peduncle_gap)
{
  const vpTranslationVector fruit_in_tool = base_R_tool.t() * vpTranslationVector(0.0, 0.0, -(radius + peduncle_gap));
  return cam_M_tool * fruit_in_tool;
}

bool currentFeature(double x, double y, const vpTranslationVector &target_cam, PointFeature &current)
{
  if (!(target_cam[2] > 0.0))
  {
    return false;
  }
  current = PointFeature(x, y, target_cam[2]);
  return true;
}

vpTranslationVector nextToolPoint(const vpRotationMatrix &cam_R_base, const vpTranslationVector &tool_base,
                                  const vpTranslationVector &step)
{
  return tool_base + cam_R_base.t() * step;
}

ServoVerdict judgeError(double error, double threshold, int moves, int max_iterations)
{
  if (error < threshold)
  {
    return ServoVerdict::CONVERGED;
  }
  if (moves >= max_iterations)
  {
    return ServoVerdict::GIVE_UP;
  }
  return ServoVerdict::MOVE;
}

std::string convergedMessage(int moves, double error, double threshold)
{
  char buf[160];
  std::snprintf(buf, sizeof(buf), "converged in %d iterations, error %.2f mm < %.2f mm", moves, error * 1e3,
                threshold * 1e3);
  return buf;
}

std::string notConvergedMessage(int moves, double error, double threshold)
{
  char buf[160];
  std::snprintf(buf, sizeof(buf), "not converged after %d iterations: error %.2f mm >= %.2f mm", moves, error * 1e3,
                threshold * 1e3);
  return buf;
}

std::string lostMessage(int lost, const std::string &why)
{
  return "target lost: not found in " + std::to_string(lost) + " consecutive hand camera images (" + why + ")";
}

std::string timeoutMessage(const char *name, double timeout)
{
  char buf[160];
  std::snprintf(buf, sizeof(buf), "%s did not answer within %.1f s", name, timeout);
  return buf;
}

std::string endedMessage(const std::string &name, const std::string &state, const std::string &text)
{
  return name + " ended " + state + (text.empty() ? "" : ": " + text);
}

void mergeJointPositions(std::vector<std::string> &names, std::vector<double> &positions,
                         const std::vector<std::string> &in_names, const std::vector<double> &in_positions)
{
  for (size_t i = 0; i < in_names.size() && i < in_positions.size(); ++i)
  {
    auto it = std::find(names.begin(), names.end(), in_names[i]);
    if (it == names.end())
    {
      names.push_back(in_names[i]);
      positions.push_back(in_positions[i]);
    }
    else
    {
      positions[it - names.begin()] = in_positions[i];
    }
  }
}

std::vector<double> selectJointPositions(const std::vector<std::string> &names, const std::vector<double> &positions,
                                         const std::vector<std::string> &wanted)
{
  std::vector<double> out;
  for (const std::string &name : wanted)
  {
    auto it = std::find(names.begin(), names.end(), name);
    if (it == names.end())
    {
      return std::vector<double>();
    }
    out.push_back(positions[it - names.begin()]);
  }
  return out;
}

}  // namespace cooperation_pkg
