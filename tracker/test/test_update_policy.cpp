// Eq. 1 fires exactly on the threshold crossings of a scripted pose / eta sequence, and
// the three methods' policies differ as the paper defines them.
#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "depowder/tracker/update_policy.hpp"

namespace {

using namespace depowder;
using namespace depowder::tracker;

struct Step {
  Pose T;
  double eta;
  bool fires;  ///< expected Eq. 1 decision
  const char* what;
};

Pose at(double x, double yaw_deg) { return makePoseRpy({x, 0.0, 0.0}, 0.0, 0.0, yaw_deg * M_PI / 180.0); }

// Dyadic thresholds (exact in binary) so that "equal to the threshold" is tested exactly.
UpdateThresholds thresholds() { return {30.0 * M_PI / 180.0, 0.0625, 0.125}; }

std::vector<Step> script() {
  const double e = 1e-9;
  return {
      {at(0.0, 0), 0.25, false, "no change"},
      {at(0.03125, 0), 0.25, false, "half of delta2"},
      {at(0.0625, 0), 0.25, false, "exactly delta2 (strict >)"},
      {at(0.0625 + e, 0), 0.25, true, "just over delta2"},
      {at(0.0625 + e, 0), 0.375, false, "eta up by exactly delta3 (strict >)"},
      {at(0.0625 + e, 0), 0.375 - e, false, "eta up by just under delta3"},
      {at(0.0625 + e, 0), 0.25 + 0.125 + 0.001, true, "eta up by more than delta3"},
      {at(0.0625 + e, 29.999), 0.376, false, "rotation just under delta1"},
      {at(0.0625 + e, 30.001), 0.376, true, "rotation just over delta1"},
      {at(0.0625 + e, 30.001), 0.376 - 0.126, true, "eta DOWN by more than delta3 (|.|)"},
      {at(0.0625 + e + 0.06, 30.001 - 29.0), 0.25 + 0.12, false, "all three below"},
      {at(0.0625 + e + 0.06, 30.001 - 29.0), 0.25 + 0.12, false, "repeat: still below"},
  };
}

TEST(UpdatePolicy, Eq1FiresExactlyOnTheCrossings) {
  UpdateReference last{at(0.0, 0), 0.25};
  int fired = 0;
  for (const Step& s : script()) {
    const UpdateDecision d = conditionalUpdate(s.T, s.eta, last, thresholds());
    EXPECT_EQ(d.update, s.fires) << s.what << " (rot " << d.rotation_change * 180 / M_PI << " deg, trans "
                                 << d.translation_change << " m, eta " << d.progress_change << ")";
    EXPECT_EQ(d.update, d.rotation || d.translation || d.progress);
    if (d.update) {
      last = {s.T, s.eta};  // Alg. 1, lines 14-16
      ++fired;
    }
  }
  EXPECT_EQ(fired, 4);
}

TEST(UpdatePolicy, NamesTheTrigger) {
  const UpdateReference last{Pose::Identity(), 0.5};
  const UpdateThresholds th = thresholds();
  UpdateDecision d = conditionalUpdate(at(0.07, 0), 0.5, last, th);
  EXPECT_TRUE(d.translation && !d.rotation && !d.progress);
  EXPECT_NEAR(d.translation_change, 0.07, 1e-15);
  d = conditionalUpdate(at(0.0, 31), 0.5, last, th);
  EXPECT_TRUE(d.rotation && !d.translation && !d.progress);
  EXPECT_NEAR(d.rotation_change, 31 * M_PI / 180, 1e-12);
  d = conditionalUpdate(Pose::Identity(), 0.3, last, th);
  EXPECT_TRUE(d.progress && !d.translation && !d.rotation);
  // Rotation about a tilted axis is measured by its geodesic angle, not per Euler angle.
  d = conditionalUpdate(makePoseRpy({0, 0, 0}, 0.3, 0.3, 0.0), 0.5, last, th);
  EXPECT_FALSE(d.rotation);  // two 17.2 deg rotations compose to 24.26 deg
  EXPECT_NEAR(d.rotation_change * 180 / M_PI, 24.2628, 1e-3);
}

// Vanilla never updates, Continuous always does, CU-ICP follows Eq. 1: over the same script.
TEST(UpdatePolicy, MethodsDifferOnlyInTheDecision) {
  for (Method m : {Method::kCu, Method::kContinuous, Method::kVanilla}) {
    UpdateReference last{at(0.0, 0), 0.25};
    for (const Step& s : script()) {
      const UpdateDecision eq1 = conditionalUpdate(s.T, s.eta, last, thresholds());
      const UpdateDecision d = decideTemplateUpdate(m, s.T, s.eta, last, thresholds());
      // The measured changes are the same for every method; only `update` differs.
      EXPECT_EQ(d.rotation, eq1.rotation);
      EXPECT_EQ(d.translation, eq1.translation);
      EXPECT_EQ(d.progress, eq1.progress);
      const bool expected = m == Method::kCu ? s.fires : m == Method::kContinuous;
      EXPECT_EQ(d.update, expected) << toString(m) << ": " << s.what;
      if (d.update) last = {s.T, s.eta};
    }
  }
}

TEST(UpdatePolicy, ThresholdsOfConfigUsePaperDefaults) {
  const UpdateThresholds th = thresholdsOf(TrackerConfig{});
  EXPECT_NEAR(th.delta1_rad, M_PI / 6, 1e-15);
  EXPECT_EQ(th.delta2, 0.05);
  EXPECT_EQ(th.delta3, 0.15);
}

TEST(UpdatePolicy, MethodNamesRoundTrip) {
  for (Method m : {Method::kCu, Method::kContinuous, Method::kVanilla}) EXPECT_EQ(methodFromString(toString(m)), m);
  EXPECT_FALSE(methodFromString("gicp").has_value());
}

}  // namespace
