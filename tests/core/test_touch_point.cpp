// Tests of core/src/touch_point.hpp, where modified flanks touch (docs/physics.md §3): the growth
// of the rigid approach against its small-slope limit R' G'^2/2, none without a profile
// modification, and its dual derivative against central differences, inside the profiles and
// where the touch point is held at a profile's end. (The growth against an independent search:
// tests/core/test_detection_effects.cpp, ProfileCrowningGivesTheParabolicTeAndItsMeshOrders; against
// CalculiX: tests/python/test_touch_point_fe.py.)
#include <gtest/gtest.h>

#include <cmath>
#include <utility>
#include <vector>

#include "dual.hpp"
#include "test_support.hpp"
#include "touch_point.hpp"

namespace {

gm_test::Pair pair_with(double slope, double crowning) {
  gm_model_params p = gm_test::paper();
  for (int g = 0; g < 2; ++g)
    for (auto& f : p.gear[g].flank) {
      f.profile_slope = g == 0 ? slope : 0.0;
      f.profile_crowning = crowning * (g + 1);
    }
  return gm_test::make_pair(p);
}

}  // namespace

TEST(TouchPoint, SmallSlopeGivesHalfRTimesTheSlopeSquared) {
  const double S = 1e-6;  // gear 1's profile slope over its active profile
  const gm_test::Pair P = pair_with(S, 0.0);
  const gm::MeshLayout& L = P.L;
  const double line = P.p.pair.center_distance * std::sin(P.g.alpha_wt);
  const double length = L.micro[0].profile_length;
  for (double f : {0.3, 0.5, 0.7}) {
    const double rho1 = L.rho_form[0] + f * (L.rho_tip[0] - L.rho_form[0]), rho2 = line - rho1;
    const double R = 1 / (1 / rho1 + 1 / rho2);
    const double slope = S / length * L.base_radius[0] / rho1;  // d gap / d arc
    gm::TouchPoint t;
    gm::touch_gain(L, 0, rho1, rho2, &t);
    EXPECT_NEAR(t.gain, 0.5 * R * slope * slope, 1e-3 * 0.5 * R * slope * slope) << f;
    EXPECT_NEAR(t.x, -R * slope, 1e-3 * R * slope) << f;
    EXPECT_EQ(t.edge, -1);
  }
  const gm_test::Pair plain = pair_with(0.0, 0.0);
  EXPECT_EQ(gm::touch_gain(plain.L, 0, 0.5 * line, 0.5 * line), 0.0);
}

TEST(TouchPoint, DualDerivativeIsTheDifferenceQuotient) {
  int at_edge = 0;
  // crowning moves the touch point towards the profiles' middles; a slope alone, towards gear 1's
  // root, onto its form circle near that end
  for (const auto& [slope, crowning] : {std::pair{2e-6, 10e-6}, std::pair{5e-6, 0.0}}) {
    const gm_test::Pair P = pair_with(slope, crowning);
    const gm::MeshLayout& L = P.L;
    const double line = P.p.pair.center_distance * std::sin(P.g.alpha_wt);
    std::vector<double> rolls;
    for (int k = 1; k < 100; ++k) rolls.push_back(L.rho_form[0] + (L.rho_tip[0] - L.rho_form[0]) * k / 100.0);
    for (double end : {1e-5, 2e-5, 5e-5}) {  // within the touch point's reach of the path's ends
      rolls.push_back(line - L.rho_tip[1] + end);  // gear 2's tip
      rolls.push_back(L.rho_tip[0] - end);         // gear 1's tip
    }
    for (const double rho1 : rolls) {
      for (double off : {-3e-4, 0.0, 3e-4}) {  // off the conjugate line as a loaded pose is
        const double rho2 = line - rho1 + off;
        gm::TouchPoint where;
        gm::touch_gain(L, 0, rho1, rho2, &where);
        if (where.edge >= 0) ++at_edge;
        for (int dir = 0; dir < 2; ++dir) {
          const gm::Dual d = gm::touch_gain(L, 0, gm::Dual(rho1, dir == 0), gm::Dual(rho2, dir == 1));
          const double e = 1e-8;
          const double up = gm::touch_gain(L, 0, rho1 + (dir == 0) * e, rho2 + (dir == 1) * e);
          const double dn = gm::touch_gain(L, 0, rho1 - (dir == 0) * e, rho2 - (dir == 1) * e);
          const double fd = (up - dn) / (2 * e);
          EXPECT_NEAR(d.d, fd, 1e-6 * std::fabs(fd) + 1e-9) << "rho1 " << rho1 << " rho2 " << rho2 << " along " << dir;
        }
      }
    }
  }
  EXPECT_GT(at_edge, 0);  // the touch point held at a profile's end is met and checked too
}
