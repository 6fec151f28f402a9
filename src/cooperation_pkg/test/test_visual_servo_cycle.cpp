/**
 * @file test_visual_servo_cycle.cpp
 * @brief gtest of the ROS-free part of the visual_servo loop (visual_servo_cycle.h): settings checks, the mode's
 *        and the goal's settings, the desired and current features, the next tool point, the stop criterion,
 *        the lost-target count, the report texts and the joint_states bookkeeping.
 */
#include <cmath>
#include <limits>
#include <stdexcept>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include <visp3/core/vpThetaUVector.h>

#include "cooperation_pkg/visual_servo_cycle.h"

using namespace cooperation_pkg;

namespace
{
const double NaN = std::numeric_limits<double>::quiet_NaN();

/** The message of the std::invalid_argument thrown by checkSettings(s), "" when none. */
std::string settingsError(const ServoSettings &s)
{
  try
  {
    checkSettings(s);
  }
  catch (const std::invalid_argument &e)
  {
    return e.what();
  }
  return "";
}

/** A valid goal: a target in base_link, every override 0 (= default). */
ServoGoalRequest validGoal()
{
  ServoGoalRequest g;
  g.x = 0.6;
  g.y = 0.1;
  g.z = 0.9;
  g.frame_id = "base_link";
  return g;
}

/** The why of goalSettings for a goal it must reject. */
std::string rejection(const ServoSettings &configured, const ServoGoalRequest &goal)
{
  ServoSettings s;
  double radius = -1.0;
  std::string why;
  EXPECT_FALSE(goalSettings(configured, goal, s, radius, why));
  EXPECT_EQ(radius, -1.0);  // untouched
  return why;
}

/**
 * Rotation of a horizontal optical frame looking along the base (and tool) x axis: camera x = -base y,
 * camera y = -base z (down), camera z = base x; i.e. cam_R_base (= cam_R_tool with the tool axes along the base's).
 */
vpRotationMatrix opticalFromBase()
{
  vpRotationMatrix R;
  const double r[3][3] = { { 0.0, -1.0, 0.0 }, { 0.0, 0.0, -1.0 }, { 1.0, 0.0, 0.0 } };
  for (unsigned int i = 0; i < 3; ++i)
  {
    for (unsigned int j = 0; j < 3; ++j)
    {
      R[i][j] = r[i][j];
    }
  }
  return R;
}

void expectPoint(const vpTranslationVector &p, double x, double y, double z)
{
  EXPECT_NEAR(p[0], x, 1e-12);
  EXPECT_NEAR(p[1], y, 1e-12);
  EXPECT_NEAR(p[2], z, 1e-12);
}
}  // namespace

TEST(ServoSettings, RequireParameterExplainsTheBadValue)
{
  EXPECT_NO_THROW(requireParameter(true, "~gain must be > 0 [1/s]"));
  try
  {
    requireParameter(false, "~gain must be > 0 [1/s]");
    FAIL() << "no exception";
  }
  catch (const std::invalid_argument &e)
  {
    EXPECT_EQ(std::string(e.what()), "invalid parameter: ~gain must be > 0 [1/s]");
  }
}

TEST(ServoSettings, CheckNamesTheFirstBadSetting)
{
  EXPECT_EQ(settingsError(ServoSettings()), "");  // the defaults are valid
  ServoSettings s;
  s.gain = 0.0;
  EXPECT_EQ(settingsError(s), "invalid parameter: ~gain must be > 0 [1/s]");
  s = ServoSettings();
  s.dt = NaN;
  EXPECT_EQ(settingsError(s), "invalid parameter: ~dt must be > 0 [s]");
  s = ServoSettings();
  s.peduncle_gap = 0.0;  // allowed: the tool centre on the fruit top
  EXPECT_EQ(settingsError(s), "");
  s.peduncle_gap = -0.001;
  EXPECT_EQ(settingsError(s), "invalid parameter: ~peduncle_gap must be >= 0 [m]");
  s = ServoSettings();
  s.max_lost = 0;
  EXPECT_EQ(settingsError(s), "invalid parameter: ~max_lost must be > 0");
  s = ServoSettings();
  s.horizon = -0.2;
  EXPECT_EQ(settingsError(s), "invalid parameter: ~horizon must be > 0 [s]");
  s = ServoSettings();
  s.continuous_max_iterations = 0;
  EXPECT_EQ(settingsError(s), "invalid parameter: ~continuous_max_iterations must be > 0");

  // Adaptive gain: 0 < gain_at_infinity < gain and a slope > 0.
  const std::string adaptive =
      "invalid parameter: adaptive gain needs 0 < ~adaptive_gain_at_infinity < ~gain and ~adaptive_slope_at_zero > 0";
  s = ServoSettings();
  s.adaptive_gain_at_infinity = 0.2;
  EXPECT_EQ(settingsError(s), adaptive);  // slope 0
  s.adaptive_slope_at_zero = 10.0;
  EXPECT_EQ(settingsError(s), "");
  s.adaptive_gain_at_infinity = 0.5;  // = gain
  EXPECT_EQ(settingsError(s), adaptive);
  s.adaptive_gain_at_infinity = -0.1;
  EXPECT_EQ(settingsError(s), adaptive);
}

TEST(ServoSettings, ModeSettingsAndHoldTime)
{
  EXPECT_STREQ(holdTimeName(ServoMode::STEP), "dt");
  EXPECT_STREQ(holdTimeName(ServoMode::CONTINUOUS), "horizon");

  ServoSettings configured;
  configured.adaptive_gain_at_infinity = 0.2;
  configured.adaptive_slope_at_zero = 10.0;
  const ServoSettings step = modeSettings(configured);
  EXPECT_EQ(step.gain, 0.5);
  EXPECT_EQ(step.dt, 1.0);
  EXPECT_EQ(step.max_iterations, 15);
  EXPECT_EQ(step.adaptive_gain_at_infinity, 0.2);  // the adaptive gain is a step-mode option

  configured.mode = ServoMode::CONTINUOUS;
  const ServoSettings continuous = modeSettings(configured);
  EXPECT_EQ(continuous.gain, 3.5);  // continuous_gain
  EXPECT_EQ(continuous.dt, 0.2);    // horizon
  EXPECT_EQ(continuous.max_iterations, 150);
  EXPECT_EQ(continuous.adaptive_gain_at_infinity, 0.0);  // constant gain
  EXPECT_EQ(continuous.threshold, 0.002);                // the rest unchanged
  EXPECT_EQ(continuous.max_step, 0.30);
}

TEST(GoalSettings, DefaultsAndOverrides)
{
  ServoSettings configured;
  configured.adaptive_gain_at_infinity = 0.2;
  configured.adaptive_slope_at_zero = 10.0;
  ServoSettings s;
  double radius = 0.0;
  std::string why;
  ASSERT_TRUE(goalSettings(configured, validGoal(), s, radius, why)) << why;
  EXPECT_EQ(s.gain, 0.5);
  EXPECT_EQ(s.adaptive_gain_at_infinity, 0.2);  // no goal gain: the configured (adaptive) gain
  EXPECT_EQ(s.threshold, 0.002);
  EXPECT_EQ(s.max_iterations, 15);
  EXPECT_EQ(radius, 0.035);  // default_radius

  ServoGoalRequest g = validGoal();
  g.target_radius = 0.04;
  g.gain = 0.3;
  g.threshold = 0.005;
  g.max_iterations = 20;
  ASSERT_TRUE(goalSettings(configured, g, s, radius, why)) << why;
  EXPECT_EQ(s.gain, 0.3);
  EXPECT_EQ(s.adaptive_gain_at_infinity, 0.0);  // an explicit gain is a constant gain
  EXPECT_EQ(s.threshold, 0.005);
  EXPECT_EQ(s.max_iterations, 20);
  EXPECT_EQ(radius, 0.04);

  // Continuous mode: the overrides apply to the mode's values; gain 3.0 * horizon 0.2 = 0.6 <= 0.8.
  configured.mode = ServoMode::CONTINUOUS;
  g = validGoal();
  g.gain = 3.0;
  ASSERT_TRUE(goalSettings(configured, g, s, radius, why)) << why;
  EXPECT_EQ(s.gain, 3.0);
  EXPECT_EQ(s.dt, 0.2);
  EXPECT_EQ(s.max_iterations, 150);
}

TEST(GoalSettings, InvalidGoalsAreExplained)
{
  const ServoSettings configured;
  ServoGoalRequest g = validGoal();
  g.y = NaN;
  EXPECT_EQ(rejection(configured, g), "invalid goal: target point is not finite");
  g = validGoal();
  g.frame_id.clear();
  EXPECT_EQ(rejection(configured, g), "invalid goal: target.header.frame_id is empty");
  for (double r : { -0.01, 0.25, NaN })
  {
    g = validGoal();
    g.target_radius = r;
    EXPECT_EQ(rejection(configured, g), "invalid goal: target_radius must be in [0, 0.2] m (0 = default)") << r;
  }
  g = validGoal();
  g.gain = -0.5;
  EXPECT_EQ(rejection(configured, g), "invalid goal: gain must be >= 0 (0 = default)");
  g = validGoal();
  g.threshold = -0.001;
  EXPECT_EQ(rejection(configured, g), "invalid goal: threshold must be >= 0 m (0 = default)");
  g = validGoal();
  g.max_iterations = -1;
  EXPECT_EQ(rejection(configured, g), "invalid goal: max_iterations must be >= 0 (0 = default)");

  // gain * dt (step) or gain * horizon (continuous) above max_gain_dt (0.8) diverges.
  g = validGoal();
  g.gain = 0.9;
  EXPECT_EQ(rejection(configured, g),
            "invalid goal: gain * dt = 0.90 exceeds 0.80 (the loop overshoots and diverges)");
  ServoSettings continuous = configured;
  continuous.mode = ServoMode::CONTINUOUS;
  g.gain = 5.0;
  EXPECT_EQ(rejection(continuous, g),
            "invalid goal: gain * horizon = 1.00 exceeds 0.80 (the loop overshoots and diverges)");
  continuous.continuous_gain = 4.5;  // the configured continuous gain is judged the same way: 0.9
  EXPECT_EQ(rejection(continuous, validGoal()),
            "invalid goal: gain * horizon = 0.90 exceeds 0.80 (the loop overshoots and diverges)");
}

TEST(ServoGeometry, DesiredTargetPoint)
{
  // Hand camera looking along the tool x axis, the tool centre 0.13 m in front of it and 0.16 m below its
  // optical axis: with radius 0.035 + gap 0.01 the fruit centre is 0.045 m below the tool centre, i.e. at
  // P* = (0, -0.16 + 0.045, 0.13): README's x* = 0, y* = -0.115, Z* = 0.13 m.
  const vpHomogeneousMatrix cam_M_tool(vpTranslationVector(0.0, -0.16, 0.13), opticalFromBase());
  expectPoint(desiredTargetPoint(cam_M_tool, vpRotationMatrix(), 0.035, 0.01), 0.0, -0.115, 0.13);
  // Any forearm yaw (rotation about the vertical): the fruit hangs below the tool centre, same P*.
  const vpRotationMatrix yawed(vpThetaUVector(0.0, 0.0, 0.7));
  expectPoint(desiredTargetPoint(cam_M_tool, yawed, 0.035, 0.01), 0.0, -0.115, 0.13);
  // A tool rolled by +90 deg about x: "below" in the base frame is the tool's -y, which the camera sees as +x.
  const vpRotationMatrix rolled(vpThetaUVector(M_PI / 2.0, 0.0, 0.0));
  expectPoint(desiredTargetPoint(cam_M_tool, rolled, 0.035, 0.01), 0.045, -0.16, 0.13);
  // No gap, radius 0.05: 0.05 below.
  expectPoint(desiredTargetPoint(cam_M_tool, vpRotationMatrix(), 0.05, 0.0), 0.0, -0.11, 0.13);
}

TEST(ServoGeometry, CurrentFeatureNeedsTheTargetInFront)
{
  PointFeature current(9.0, 9.0, 9.0);
  ASSERT_TRUE(currentFeature(0.04, -0.08, vpTranslationVector(0.01, -0.02, 0.25), current));
  EXPECT_EQ(current.x, 0.04);  // the image point, not the projection of target_cam
  EXPECT_EQ(current.y, -0.08);
  EXPECT_EQ(current.Z, 0.25);  // depth of the target in the camera frame
  for (double z : { 0.0, -0.1, NaN })
  {
    PointFeature untouched(9.0, 9.0, 9.0);
    EXPECT_FALSE(currentFeature(0.0, 0.0, vpTranslationVector(0.0, 0.0, z), untouched)) << z;
    EXPECT_EQ(untouched.Z, 9.0);
  }
}

TEST(ServoGeometry, NextToolPointMovesWithTheCamera)
{
  // Camera step (0.01 right, 0.02 down, 0.05 forward) of a camera looking along base x: in the base frame
  // (+0.05 x, -0.01 y, -0.02 z).
  const vpTranslationVector tool(0.5, 0.1, 0.9);
  expectPoint(nextToolPoint(opticalFromBase(), tool, vpTranslationVector(0.01, 0.02, 0.05)), 0.55, 0.09, 0.88);
  expectPoint(nextToolPoint(opticalFromBase(), tool, vpTranslationVector(0.0, 0.0, 0.0)), 0.5, 0.1, 0.9);
  // The camera yawed by 90 deg (looking along base y): forward is base +y.
  const vpRotationMatrix yawed = opticalFromBase() * vpRotationMatrix(vpThetaUVector(0.0, 0.0, -M_PI / 2.0));
  expectPoint(nextToolPoint(yawed, tool, vpTranslationVector(0.0, 0.0, 0.05)), 0.5, 0.15, 0.9);
}

TEST(ServoPolicy, StopCriterion)
{
  EXPECT_EQ(judgeError(0.001, 0.002, 0, 15), ServoVerdict::CONVERGED);
  EXPECT_EQ(judgeError(0.001, 0.002, 15, 15), ServoVerdict::CONVERGED);  // convergence wins at the last move
  EXPECT_EQ(judgeError(0.003, 0.002, 15, 15), ServoVerdict::GIVE_UP);
  EXPECT_EQ(judgeError(0.003, 0.002, 14, 15), ServoVerdict::MOVE);
  EXPECT_EQ(judgeError(0.002, 0.002, 3, 15), ServoVerdict::MOVE);  // strictly below the threshold
  EXPECT_EQ(judgeError(NaN, 0.002, 0, 15), ServoVerdict::MOVE);
  EXPECT_EQ(judgeError(NaN, 0.002, 15, 15), ServoVerdict::GIVE_UP);
}

TEST(ServoPolicy, LostTargetCount)
{
  LostTargetCount lost(3);
  EXPECT_EQ(lost.count(), 0);
  EXPECT_FALSE(lost.miss());
  EXPECT_FALSE(lost.miss());
  EXPECT_EQ(lost.count(), 2);
  EXPECT_EQ(lost.found(), 2);  // seen again after 2 misses
  EXPECT_EQ(lost.count(), 0);
  EXPECT_EQ(lost.found(), 0);
  EXPECT_FALSE(lost.miss());
  EXPECT_FALSE(lost.miss());
  EXPECT_TRUE(lost.miss());  // the 3rd consecutive miss aborts
  EXPECT_EQ(lost.count(), 3);
  LostTargetCount once(1);
  EXPECT_TRUE(once.miss());
}

TEST(ServoPolicy, ReportTexts)
{
  EXPECT_EQ(convergedMessage(6, 0.0011, 0.002), "converged in 6 iterations, error 1.10 mm < 2.00 mm");
  EXPECT_EQ(notConvergedMessage(15, 0.0123, 0.002), "not converged after 15 iterations: error 12.30 mm >= 2.00 mm");
  EXPECT_EQ(lostMessage(3, "no tomato in the hand camera image"),
            "target lost: not found in 3 consecutive hand camera images (no tomato in the hand camera image)");
  EXPECT_EQ(timeoutMessage("kinematics", 5.0), "kinematics did not answer within 5.0 s");
  EXPECT_EQ(timeoutMessage("move_robot", 30.0), "move_robot did not answer within 30.0 s");
  EXPECT_EQ(endedMessage("move_robot", "ABORTED", "halted"), "move_robot ended ABORTED: halted");
  EXPECT_EQ(endedMessage("image_processing", "PREEMPTED", ""), "image_processing ended PREEMPTED");
}

TEST(JointStates, MergeKeepsTheLatestOfEveryJoint)
{
  std::vector<std::string> names;
  std::vector<double> positions;
  mergeJointPositions(names, positions, { "left_lift_joint", "left_boom_joint" }, { 0.1, 0.2 });
  mergeJointPositions(names, positions, { "left_boom_joint", "left_forearm_joint" }, { 0.5, 0.6 });
  EXPECT_EQ(names, (std::vector<std::string>{ "left_lift_joint", "left_boom_joint", "left_forearm_joint" }));
  EXPECT_EQ(positions, (std::vector<double>{ 0.1, 0.5, 0.6 }));
  // More names than positions: the unpaired name is ignored.
  mergeJointPositions(names, positions, { "waist_joint", "right_lift_joint" }, { 0.7 });
  EXPECT_EQ(names.size(), 4u);
  EXPECT_EQ(names.back(), "waist_joint");
  EXPECT_EQ(positions.back(), 0.7);
}

TEST(JointStates, SelectInTheWantedOrder)
{
  const std::vector<std::string> names{ "waist_joint", "left_forearm_joint", "left_lift_joint", "left_boom_joint" };
  const std::vector<double> positions{ 0.0, 0.3, 0.1, 0.2 };
  const std::vector<std::string> left{ "left_lift_joint", "left_boom_joint", "left_forearm_joint" };
  EXPECT_EQ(selectJointPositions(names, positions, left), (std::vector<double>{ 0.1, 0.2, 0.3 }));
  const std::vector<std::string> partial(names.begin(), names.begin() + 3);  // no boom
  EXPECT_TRUE(selectJointPositions(partial, positions, left).empty());
}

namespace
{
/** A camera at `origin` (base frame) looking along base +x (optical z), its x to base -y, its y down. */
vpHomogeneousMatrix cameraAt(double ox, double oy, double oz, double yaw = 0.0)
{
  vpRotationMatrix look;  // columns: camera x, y, z in the base frame
  look[0][0] = 0.0, look[0][1] = 0.0, look[0][2] = 1.0;
  look[1][0] = -1.0, look[1][1] = 0.0, look[1][2] = 0.0;
  look[2][0] = 0.0, look[2][1] = -1.0, look[2][2] = 0.0;
  const vpRotationMatrix turn(vpThetaUVector(0.0, 0.0, yaw));
  return vpHomogeneousMatrix(vpTranslationVector(ox, oy, oz), turn * look);
}

/** The normalized image point of base point p seen from base_M_cam. */
void imagePoint(const vpHomogeneousMatrix &base_M_cam, const vpTranslationVector &p, double &x, double &y)
{
  const vpTranslationVector c = base_M_cam.inverse() * p;
  x = c[0] / c[2];
  y = c[1] / c[2];
}
}  // namespace

TEST(DepthProbe, RangesTheFruitFromTwoSidewaysPoses)
{
  const vpTranslationVector fruit(0.52, -0.10, 0.86);
  const vpHomogeneousMatrix cam1 = cameraAt(0.36, -0.09, 0.98, 0.1);
  const vpHomogeneousMatrix cam2 = cameraAt(0.36, -0.12, 0.98, 0.1);  // 3 cm to the side
  double x1, y1, x2, y2;
  imagePoint(cam1, fruit, x1, y1);
  imagePoint(cam2, fruit, x2, y2);
  // the stereo head's target 15 mm too far: the probe ranges the true centre
  const vpTranslationVector stereo = fruit + vpTranslationVector(0.015, 0.0, 0.0);
  const ProbeFix fix = triangulateProbe(cam1, x1, y1, cam2, x2, y2, stereo, 0.05, 0.01);
  ASSERT_TRUE(fix.ok) << fix.why;
  EXPECT_NEAR((fix.point - fruit).frobeniusNorm(), 0.0, 1e-9);
  EXPECT_NEAR(fix.gap, 0.0, 1e-9);
  // half a pixel of error (f = 500 px) in the second image moves the depth by a few mm only
  const ProbeFix noisy = triangulateProbe(cam1, x1, y1, cam2, x2 + 0.5 / 500.0, y2, stereo, 0.05, 0.01);
  ASSERT_TRUE(noisy.ok) << noisy.why;
  EXPECT_LT((noisy.point - fruit).frobeniusNorm(), 0.004);
}

TEST(DepthProbe, RefusesWhatItCannotRange)
{
  const vpTranslationVector fruit(0.52, -0.10, 0.86);
  const vpHomogeneousMatrix cam1 = cameraAt(0.36, -0.09, 0.98);
  double x1, y1, x2, y2;
  imagePoint(cam1, fruit, x1, y1);
  // no sideways move: parallel rays
  ProbeFix fix = triangulateProbe(cam1, x1, y1, cam1, x1, y1, fruit, 0.05, 0.01);
  EXPECT_FALSE(fix.ok);
  EXPECT_NE(fix.why.find("parallel"), std::string::npos) << fix.why;
  // the centre far from the stereo target (another fruit taken for it)
  const vpHomogeneousMatrix cam2 = cameraAt(0.36, -0.12, 0.98);
  imagePoint(cam2, fruit, x2, y2);
  fix = triangulateProbe(cam1, x1, y1, cam2, x2, y2, fruit + vpTranslationVector(0.0, 0.08, 0.0), 0.05, 0.01);
  EXPECT_FALSE(fix.ok);
  EXPECT_NE(fix.why.find("from the target"), std::string::npos) << fix.why;
  // a neighbour 25 mm to the side (a cherry truss): refused; 25 mm further along the view: taken
  fix = triangulateProbe(cam1, x1, y1, cam2, x2, y2, fruit + vpTranslationVector(0.0, 0.025, 0.0), 0.05, 0.01);
  EXPECT_FALSE(fix.ok);
  EXPECT_NE(fix.why.find("to the side"), std::string::npos) << fix.why;
  fix = triangulateProbe(cam1, x1, y1, cam2, x2, y2, fruit + vpTranslationVector(0.025, 0.0, 0.0), 0.05, 0.01);
  EXPECT_TRUE(fix.ok) << fix.why;
  // rays that miss each other by a centimetre (the feature jumped between the images)
  fix = triangulateProbe(cam1, x1, y1 + 0.06, cam2, x2, y2, fruit, 0.05, 0.01);
  EXPECT_FALSE(fix.ok);
  EXPECT_NE(fix.why.find("apart"), std::string::npos) << fix.why;
  // crossing behind the cameras
  fix = triangulateProbe(cam1, -x1 - 0.4, y1, cam2, x2, y2, fruit, 0.05, 0.01);
  EXPECT_FALSE(fix.ok);
  // a non-finite image point
  fix = triangulateProbe(cam1, NaN, y1, cam2, x2, y2, fruit, 0.05, 0.01);
  EXPECT_FALSE(fix.ok);
}

TEST(DepthProbe, SettingsAreChecked)
{
  ServoSettings s;
  EXPECT_EQ(settingsError(s), "");
  s.depth_probe = -0.01;
  EXPECT_NE(settingsError(s).find("depth_probe"), std::string::npos);
  s.depth_probe = 0.03;
  EXPECT_EQ(settingsError(s), "");
  s.depth_probe_max_shift = 0.0;
  EXPECT_NE(settingsError(s).find("depth_probe_max_shift"), std::string::npos);
  s.depth_probe_max_shift = 0.05;
  s.depth_probe_max_side = NaN;
  EXPECT_NE(settingsError(s).find("depth_probe_max_side"), std::string::npos);
}

int main(int argc, char **argv)
{
  testing::InitGoogleTest(&argc, argv);
  return RUN_ALL_TESTS();
}
