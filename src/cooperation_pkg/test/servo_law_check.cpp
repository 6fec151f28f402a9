/**
 * @file servo_law_check.cpp
 * @brief Test helper (not installed): evaluates VisualServoControl on feature sets read from stdin.
 *
 * One case per input line:  MODE x y Z x* y* Z* GAIN [GAIN_INF SLOPE0]
 *   MODE  t = translation-only law, f = full 6-DOF law; GAIN_INF and SLOPE0 select the adaptive gain.
 * One output line per case: vx vy vz wx wy wz e_x e_y e_logZ error_at_target_m gain_used
 * or "error MESSAGE" for a rejected case. Used by test/test_servo_law.py against ibvs_reference.py.
 */
#include <cstdio>
#include <iostream>
#include <sstream>
#include <stdexcept>
#include <string>

#include "cooperation_pkg/visual_servo_control.h"

int main()
{
  std::string line;
  while (std::getline(std::cin, line))
  {
    if (line.empty() || line[0] == '#')
    {
      continue;
    }
    std::istringstream in(line);
    std::string mode;
    double x, y, Z, xs, ys, Zs, gain;
    if (!(in >> mode >> x >> y >> Z >> xs >> ys >> Zs >> gain))
    {
      std::printf("error unparsable line\n");
      continue;
    }
    double gain_inf = 0.0, slope = 0.0;
    const bool adaptive = static_cast<bool>(in >> gain_inf >> slope);
    try
    {
      cooperation_pkg::VisualServoControl law(
          gain, mode == "f" ? cooperation_pkg::VisualServoControl::FULL : cooperation_pkg::VisualServoControl::TRANSLATION);
      if (adaptive)
      {
        law.setAdaptiveGain(gain, gain_inf, slope);
      }
      law.setDesired(cooperation_pkg::PointFeature(xs, ys, Zs));
      const cooperation_pkg::PointFeature cur(x, y, Z);
      const vpColVector v = law.computeControlLaw(cur);
      const vpColVector e = law.featureError();
      for (unsigned int i = 0; i < v.size(); ++i)
      {
        std::printf("%.17g ", v[i]);
      }
      for (unsigned int i = 0; i < e.size(); ++i)
      {
        std::printf("%.17g ", e[i]);
      }
      std::printf("%.17g %.17g\n", law.errorAtTarget(cur), law.lastGain());
    }
    catch (const std::exception &ex)
    {
      std::printf("error %s\n", ex.what());
    }
  }
  return 0;
}
