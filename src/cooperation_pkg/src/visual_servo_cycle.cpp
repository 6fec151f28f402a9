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

double dot3(const vpTranslationVector &a, const vpTranslationVector &b)
{
  return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
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
  requireParameter(finite(s.depth_probe) && s.depth_probe >= 0.0 && s.depth_probe <= 0.1,
                   "~depth_probe must be in [0, 0.1] [m]");
  requireParameter(finite(s.depth_probe_max_shift) && s.depth_probe_max_shift > 0.0,
                   "~depth_probe_max_shift must be > 0 [m]");
  requireParameter(finite(s.depth_probe_max_side) && s.depth_probe_max_side > 0.0,
                   "~depth_probe_max_side must be > 0 [m]");
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

ProbeFix triangulateProbe(const vpHomogeneousMatrix &base_M_cam1, double x1, double y1,
                          const vpHomogeneousMatrix &base_M_cam2, double x2, double y2,
                          const vpTranslationVector &expected, double max_shift, double max_side, double max_gap)
{
  ProbeFix fix;
  const vpTranslationVector o1 = base_M_cam1.getTranslationVector();
  const vpTranslationVector o2 = base_M_cam2.getTranslationVector();
  vpTranslationVector d1 = base_M_cam1.getRotationMatrix() * vpTranslationVector(x1, y1, 1.0);
  vpTranslationVector d2 = base_M_cam2.getRotationMatrix() * vpTranslationVector(x2, y2, 1.0);
  const double n1 = d1.frobeniusNorm();
  const double n2 = d2.frobeniusNorm();
  if (!(n1 > 0.0) || !(n2 > 0.0) || !std::isfinite(n1) || !std::isfinite(n2))
  {
    fix.why = "no viewing ray (non-finite image point)";
    return fix;
  }
  d1 = d1 / n1;
  d2 = d2 / n2;
  // closest points o1 + t1 d1, o2 + t2 d2: solve [1 -b; b -1] (t1, t2) = (d1.w, d2.w), w = o2 - o1
  const vpTranslationVector w = o2 - o1;
  const double b = dot3(d1, d2);
  const double den = 1.0 - b * b;
  if (den < std::pow(std::sin(0.5 * M_PI / 180.0), 2))
  {
    fix.why = "the two viewing rays are nearly parallel (the camera did not move sideways enough)";
    return fix;
  }
  const double e1 = dot3(d1, w);
  const double e2 = dot3(d2, w);
  const double t1 = (e1 - b * e2) / den;
  const double t2 = (b * e1 - e2) / den;
  if (!(t1 > 0.0) || !(t2 > 0.0))
  {
    fix.why = "the ranged point is not in front of both camera poses";
    return fix;
  }
  const vpTranslationVector p1 = o1 + d1 * t1;
  const vpTranslationVector p2 = o2 + d2 * t2;
  fix.gap = (p1 - p2).frobeniusNorm();
  fix.point = (p1 + p2) * 0.5;
  char text[160];
  if (!(fix.gap <= max_gap))
  {
    std::snprintf(text, sizeof(text), "the viewing rays pass %.1f mm apart (> %.1f mm)", fix.gap * 1e3,
                  max_gap * 1e3);
    fix.why = text;
    return fix;
  }
  const vpTranslationVector offset = fix.point - expected;
  const double shift = offset.frobeniusNorm();
  if (!(shift <= max_shift))
  {
    std::snprintf(text, sizeof(text), "the ranged centre is %.1f mm from the target (> %.1f mm)", shift * 1e3,
                  max_shift * 1e3);
    fix.why = text;
    return fix;
  }
  vpTranslationVector axis = base_M_cam1.getRotationMatrix() * vpTranslationVector(0.0, 0.0, 1.0);
  const double along = dot3(offset, axis);
  const double side = std::sqrt(std::max(shift * shift - along * along, 0.0));
  if (!(side <= max_side))
  {
    std::snprintf(text, sizeof(text), "the ranged centre is %.1f mm to the side of the target (> %.1f mm): another "
                  "fruit?", side * 1e3, max_side * 1e3);
    fix.why = text;
    return fix;
  }
  fix.ok = true;
  return fix;
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
