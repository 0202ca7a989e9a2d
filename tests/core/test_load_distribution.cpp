// The load across the face (gm_data_load_distribution, gm_model_slice_positions) against closed
// forms at level 0, whose line load is the constant stiffness per unit face width times the
// slice's approach: uniform over the face of an aligned spur pair, the parabola of lead
// crowning and a helix slope; and the pairs' sums against the evaluation's own outputs at levels 4 and 5.
#include <gtest/gtest.h>

#include <algorithm>
#include <numeric>
#include <string>
#include <vector>

#include "fe_synthetic.hpp"
#include "test_support.hpp"

namespace {

using namespace gm_test;

constexpr int kSlices = 10;
constexpr int kMaxPairs = 4;
constexpr double kTe = 5e-6;  // m

struct Distribution {
  int n = 0;
  gm_pair_load pairs[kMaxPairs];
  std::vector<double> line_load = std::vector<double>(kMaxPairs * kSlices, -1.0);
};

Distribution distribution(const Instance& inst) {
  Distribution d;
  d.n = gm_data_load_distribution(inst.m, inst.d, kMaxPairs, d.pairs, d.line_load.data());
  return d;
}

gm_model_params level0(int slices) {
  gm_model_params p = paper();
  p.slices = slices;
  return p;
}

// What every evaluation's distribution adds up to: its pairs, normal force, largest line load
// and load share; rows past the loaded pairs zero; the pairs in order on the path of contact.
void expect_consistent(const Distribution& d, const gm_result& r) {
  ASSERT_EQ(d.n, r.pairs_in_contact);
  ASSERT_LE(d.n, kMaxPairs);
  double force = 0, share = 0, largest_share = 0, largest_line_load = 0;
  for (int k = 0; k < d.n; ++k) {
    const gm_pair_load& p = d.pairs[k];
    force += p.force;
    share += p.share;
    largest_share = std::max(largest_share, p.share);
    EXPECT_GE(p.path_position, -1e-9);
    EXPECT_LE(p.path_position, 1 + 1e-9);
    if (k > 0 && d.pairs[k - 1].flank == p.flank) EXPECT_LT(d.pairs[k - 1].path_position, p.path_position);
    for (int j = 0; j < kSlices; ++j) largest_line_load = std::max(largest_line_load, d.line_load[k * kSlices + j]);
  }
  EXPECT_NEAR(force, r.normal_force, 1e-12 * r.normal_force);
  EXPECT_NEAR(share, 1.0, 1e-12);
  EXPECT_NEAR(largest_share, r.max_load_share, 1e-12);
  EXPECT_DOUBLE_EQ(largest_line_load, r.max_line_load);
  for (int k = d.n; k < kMaxPairs; ++k) {
    EXPECT_EQ(d.pairs[k].force, 0.0);
    for (int j = 0; j < kSlices; ++j) EXPECT_EQ(d.line_load[k * kSlices + j], 0.0);
  }
}

TEST(LoadDistribution, SlicePositionsSplitTheOverlapEvenly) {
  gm_model_params p = level0(kSlices);
  p.gear[1].face_width = 20e-3;  // gear 2 narrower and off-centre: the overlap is its face
  p.gear[1].axial_offset = 1e-3;
  Instance inst(p);
  double z[kSlices];
  gm_model_slice_positions(inst.m, z);
  for (int j = 0; j < kSlices; ++j) EXPECT_NEAR(z[j], 1e-3 - 10e-3 + (j + 0.5) * 2e-3, 1e-15);
}

TEST(LoadDistribution, AlignedSpurPairIsUniformAtStiffnessTimesApproach) {
  Instance inst(level0(kSlices));
  const double c = gm_model_parameters(inst.m)->user_stiffness;  // N/m per m of face
  const double b = 23e-3;
  // gear 1 over a base pitch: one and two pairs, flank and tip contact
  const double pitch = inst.geo().p_bt / inst.rb(0);
  for (int s = 0; s < 8; ++s) {
    SCOPED_TRACE(s);
    const gm_result r = inst.at(kTe, pitch * s / 8);
    const Distribution d = distribution(inst);
    expect_consistent(d, r);
    // each slice of a pair closes by the pair's approach: q = c Delta, the same over the face
    for (int k = 0; k < d.n; ++k) {
      EXPECT_NEAR(d.pairs[k].force, c * d.pairs[k].approach * b, 1e-9 * c * kTe * b);
      for (int j = 0; j < kSlices; ++j)
        EXPECT_NEAR(d.line_load[k * kSlices + j], c * d.pairs[k].approach, 1e-9 * c * kTe);
    }
  }
  // at the pitch point a single pair in flank contact closes by the TE itself
  const gm_result r = inst.at(kTe, 0.0);
  ASSERT_EQ(r.pairs_in_contact, 1);
  const Distribution d = distribution(inst);
  EXPECT_NEAR(d.pairs[0].approach, kTe, 1e-15);
  for (int j = 0; j < kSlices; ++j) EXPECT_NEAR(d.line_load[j], c * kTe, 1e-9 * c * kTe);
}

TEST(LoadDistribution, LeadCrowningAndHelixSlopeLoadTheirGapsParabola) {
  const double crowning = 4e-6, slope = 2e-6, b = 23e-3;
  gm_model_params p = level0(kSlices);
  for (auto& f : p.gear[0].flank) {
    f.lead_crowning = crowning;
    f.helix_slope = slope;  // not symmetric: the slices are not mirrored
  }
  Instance inst(p);
  const double c = p.user_stiffness;
  double z[kSlices];
  gm_model_slice_positions(inst.m, z);
  const gm_result r = inst.at(kTe, 0.0);  // one pair at the pitch point, in flank contact
  const Distribution d = distribution(inst);
  expect_consistent(d, r);
  ASSERT_EQ(d.n, 1);
  for (int k = 0; k < d.n; ++k) {
    for (int j = 0; j < kSlices; ++j) {
      // the gap C (2 y / b)^2 + f y / b at the slice centre y = z_j (gear 1 centred); q >= 0
      const double y = z[j];
      const double expected = c * std::max(kTe - crowning * (2 * y / b) * (2 * y / b) - slope * y / b, 0.0);
      EXPECT_NEAR(d.line_load[k * kSlices + j], expected, 1e-9 * c * kTe) << "pair " << k << " slice " << j;
    }
  }
}

TEST(LoadDistribution, ParticularLoadsOfLevelsFourAndFiveAddUpToTheOutputs) {
  for (int level : {4, 5}) {
    SCOPED_TRACE(level);
    gm_model_params p = level0(kSlices);
    p.stiffness_level = static_cast<gm_stiffness_level>(level);
    p.gear[0].flank[0].lead_crowning = 6e-6;  // a face that is not uniform
    std::string db[2];
    if (level == 5) {
      p.coupled_teeth = 2;
      for (int g = 0; g < 2; ++g) {
        std::string msg;
        db[g] = write_smooth_db(p, g, "load_distribution_gear" + std::to_string(g + 1) + ".gcdb", msg);
        ASSERT_FALSE(db[g].empty()) << msg;
        p.compliance[g] = db[g].c_str();
      }
    }
    Instance inst(p);
    for (double phi1 : {0.0, 0.013, 0.027}) {
      const gm_result r = inst.at(8e-6, phi1);
      expect_consistent(distribution(inst), r);
    }
    // a failed evaluation leaves no distribution
    gm_kinematics bad{};
    bad.phi[0] = std::nan("");
    gm_result r{};
    EXPECT_NE(gm_evaluate(inst.m, inst.d, &bad, &r), GM_OK);
    EXPECT_EQ(gm_data_load_distribution(inst.m, inst.d, kMaxPairs, nullptr, nullptr), 0);
  }
}

TEST(LoadDistribution, MorePairsThanRowsWritesTheFirstAndCountsAll) {
  Instance inst(level0(kSlices));
  const double pitch = inst.geo().p_bt / inst.rb(0);
  gm_result r{};
  for (int s = 0; s < 16 && r.pairs_in_contact < 2; ++s) r = inst.at(kTe, pitch * s / 16);
  ASSERT_GE(r.pairs_in_contact, 2);
  gm_pair_load one[1];
  std::vector<double> row(kSlices, -1.0);
  EXPECT_EQ(gm_data_load_distribution(inst.m, inst.d, 1, one, row.data()), r.pairs_in_contact);
  const Distribution all = distribution(inst);
  EXPECT_EQ(one[0].force, all.pairs[0].force);
  for (int j = 0; j < kSlices; ++j) EXPECT_EQ(row[j], all.line_load[j]);
}

// The slices' record (index, merged run) is written afresh by each evaluation: a pose sweep on one
// instance gives each pose's result bit for bit as a fresh instance does, with profile crowning
// (slices merged by slice_merge.hpp) and without (merged by detection), where the merged runs
// and the candidates' places change from pose to pose.
TEST(LoadDistribution, EvaluationIsTheSameWhateverCameBefore) {
  for (double crowning : {0.0, 5e-6}) {
    SCOPED_TRACE(crowning);
    gm_model_params p = level0(kSlices);
    p.gear[0].flank[0].profile_crowning = crowning;
    Instance sweep(p);
    const double pitch = sweep.geo().p_bt / sweep.rb(0);
    for (int s = 0; s < 16; ++s) {
      const gm_result a = sweep.at(kTe, pitch * s / 16);
      const Distribution da = distribution(sweep);
      Instance fresh(p);
      const gm_result b = fresh.at(kTe, pitch * s / 16);
      const Distribution db = distribution(fresh);
      for (int g = 0; g < 2; ++g)
        for (int k = 0; k < 3; ++k) {
          EXPECT_EQ(a.force[g][k], b.force[g][k]) << "pose " << s;
          EXPECT_EQ(a.moment[g][k], b.moment[g][k]) << "pose " << s;
        }
      EXPECT_EQ(a.normal_force, b.normal_force) << "pose " << s;
      EXPECT_EQ(a.stiffness, b.stiffness) << "pose " << s;
      EXPECT_EQ(a.elastic_energy, b.elastic_energy) << "pose " << s;
      EXPECT_EQ(da.line_load, db.line_load) << "pose " << s;
    }
  }
}

}  // namespace
