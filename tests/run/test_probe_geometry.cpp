// The probes' directions and load programs (run/probes.hpp): stress directions are unit vectors in their plane
// (Rendulic: ds22 = ds33; deviatoric: no change of p), strain probes name each of the six strains once, and a
// probe's legs load by exactly M d over `steps` and give it back.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "run/probes.hpp"

namespace celldem {
namespace {

ProbeDef stress_probes(ProbePlane plane, int directions) {
  ProbeDef def;
  def.at = {"end"};
  def.plane = plane;
  def.directions = directions;
  def.magnitudes = {1000.0, 3000.0};
  def.steps = 200;
  def.hold_steps = 50;
  return def;
}

double length(const std::array<double, 6>& d) {
  double s = 0.0;
  for (double x : d) s += x * x;
  return std::sqrt(s);
}

TEST(ProbeDirections, RendulicAndDeviatoricPlanes) {
  for (const ProbePlane plane : {ProbePlane::Rendulic, ProbePlane::Deviatoric}) {
    const std::vector<ProbeDirection> all = probe_directions(stress_probes(plane, 12));
    ASSERT_EQ(all.size(), 1u + 2u * 12u);
    EXPECT_EQ(all[0].name, "reference");
    EXPECT_EQ(all[0].magnitude, 0.0);
    for (std::size_t i = 1; i < all.size(); ++i) {
      const ProbeDirection& p = all[i];
      EXPECT_NEAR(length(p.direction), 1.0, 1e-14) << p.name;
      if (plane == ProbePlane::Rendulic) {
        EXPECT_DOUBLE_EQ(p.direction[1], p.direction[2]) << p.name;
      } else {
        EXPECT_NEAR(p.direction[0] + p.direction[1] + p.direction[2], 0.0, 1e-14) << p.name;
      }
      if (i <= 6) {  // directions k and k + n/2 are opposite
        for (int k = 0; k < 3; ++k) EXPECT_NEAR(p.direction[k], -all[i + 6].direction[k], 1e-14) << p.name;
      }
    }
    EXPECT_EQ(all[1].name, "m1-d00");
    EXPECT_EQ(all[13].name, "m2-d00");
    EXPECT_DOUBLE_EQ(all[13].magnitude, 3000.0);
  }
  // a = 0: axial compression in the Rendulic plane, triaxial compression in the deviatoric plane.
  const ProbeDirection r = probe_directions(stress_probes(ProbePlane::Rendulic, 4))[1];
  EXPECT_EQ(r.direction[0], 1.0);
  const ProbeDirection d = probe_directions(stress_probes(ProbePlane::Deviatoric, 4))[1];
  EXPECT_GT(d.direction[0], 0.0);
  EXPECT_DOUBLE_EQ(d.direction[1], d.direction[2]);
}

TEST(ProbeDirections, StrainProbesNameTheSixStrains) {
  ProbeDef def;
  def.kind = ProbeKind::Strain;
  def.magnitudes = {1e-5};
  const std::vector<ProbeDirection> all = probe_directions(def);
  ASSERT_EQ(all.size(), 7u);
  const char* names[] = {"e11", "e22", "e33", "g12", "g13", "g23"};
  for (int k = 0; k < 6; ++k) {
    EXPECT_EQ(all[k + 1].name, names[k]);
    EXPECT_EQ(all[k + 1].direction[k], 1.0);
    EXPECT_EQ(length(all[k + 1].direction), 1.0);
  }
}

TEST(ProbeLegs, StressProbeRampsToItsTargetAndBack) {
  const ProbeDef def = stress_probes(ProbePlane::Rendulic, 8);
  const ProbeDirection p = probe_directions(def)[2];  // m1-d01: a = 45 deg
  const Vec3 s(2e5, 1e5, 1e5);
  const double dt = 1e-6;
  const std::vector<Leg> legs = probe_legs(def, p, s, dt);
  ASSERT_EQ(legs.size(), 4u);
  const double ramp = static_cast<double>(def.steps) * dt;
  for (int k = 0; k < 3; ++k) {
    const double to = s[k] + p.magnitude * p.direction[k];
    EXPECT_EQ(legs[0].axes[k].mode, AxisMode::StressRamp);
    EXPECT_NEAR(legs[0].axes[k].stress_target(ramp), to, 1e-9 * to);    // loaded at the end of the ramp
    EXPECT_EQ(legs[1].axes[k].mode, AxisMode::Stress);
    EXPECT_DOUBLE_EQ(legs[1].axes[k].value, to);
    EXPECT_NEAR(legs[2].axes[k].stress_target(ramp), s[k], 1e-9 * s[k]);  // given back
    EXPECT_DOUBLE_EQ(legs[3].axes[k].value, s[k]);
  }
  for (const Leg& leg : legs) {
    EXPECT_EQ(leg.end.kind, LegEndKind::Steps);
    for (int a = 3; a < kComponents; ++a) EXPECT_EQ(leg.axes[a].mode, AxisMode::Held);  // tilts held
  }
  EXPECT_EQ(legs[0].end.steps, def.steps);
  EXPECT_EQ(legs[1].end.steps, def.hold_steps);
}

TEST(ProbeLegs, StrainProbeMovesOneStrainByM) {
  ProbeDef def;
  def.kind = ProbeKind::Strain;
  def.magnitudes = {2e-5};
  def.steps = 400;
  const std::vector<ProbeDirection> all = probe_directions(def);
  for (int k = 0; k < 6; ++k) {
    const std::vector<Leg> legs = probe_legs(def, all[k + 1], Vec3(1e5, 1e5, 1e5), 1e-6);
    for (int phase = 0; phase < 4; ++phase) {
      const double sign = phase == 0 ? 1.0 : phase == 2 ? -1.0 : 0.0;
      for (int j = 0; j < 3; ++j) {
        EXPECT_EQ(legs[phase].axes[j].mode, AxisMode::StrainIncrement);
        EXPECT_DOUBLE_EQ(legs[phase].strain_per_step(j, 1e-6), j == k ? sign * 2e-5 / 400 : 0.0);
      }
      for (int a = 0; a < 3; ++a)
        EXPECT_DOUBLE_EQ(legs[phase].strain_per_step(3 + a, 1e-6), 3 + a == k ? sign * 2e-5 / 400 : 0.0);
    }
  }
}


// The judgement of a probed point (judge_probe_point) on constructed evidence: a rested point whose reference stays
// still, whose recovered strains match C_elastic^-1 ds and whose elastic stiffness is symmetric positive definite
// passes; each failed check is named, in order, and only those.
ProbeEvidence good_evidence() {
  ProbeEvidence e;
  e.rest_reached = true;
  e.rest_creep = 5e-7;
  e.drift = 1e-7;
  e.smallest_response = 1e-5;
  e.elastic_asymmetry = 0.01;
  e.elastic_min_eigenvalue = 2e7;
  e.elastic_factor = 1.4;
  return e;
}

bool names(const ProbeVerdict& v, std::string_view check) {
  return std::find(v.failed.begin(), v.failed.end(), check) != v.failed.end();
}

TEST(ProbeJudgement, ARestedConsistentPointPasses) {
  const ProbeDef def = stress_probes(ProbePlane::Rendulic, 8);
  const ProbeVerdict v = judge_probe_point(def, good_evidence());
  EXPECT_TRUE(v.failed.empty()) << v.reason;
  EXPECT_TRUE(v.reason.empty());
}

TEST(ProbeJudgement, EachFailedCheckIsNamed) {
  const ProbeDef def = stress_probes(ProbePlane::Rendulic, 8);  // default limits: drift 0.25, factor 3, asymmetry 0.1
  ProbeEvidence e = good_evidence();
  e.drift = 5.4e-4;  // the review's creeping reference: 54x the response
  ProbeVerdict v = judge_probe_point(def, e);
  ASSERT_EQ(v.failed.size(), 1u);
  EXPECT_EQ(v.failed[0], "drifting");
  EXPECT_NE(v.reason.find("54"), std::string::npos) << v.reason;  // the ratio is stated

  e = good_evidence();
  e.drift = 0.24e-5;  // within the limit: passes
  EXPECT_TRUE(judge_probe_point(def, e).failed.empty());
  e.drift = 0.26e-5;
  EXPECT_TRUE(names(judge_probe_point(def, e), "drifting"));

  e = good_evidence();
  e.rest_reached = false;
  v = judge_probe_point(def, e);
  ASSERT_EQ(v.failed.size(), 1u);
  EXPECT_EQ(v.failed[0], "not at rest");

  e = good_evidence();
  e.drift = 0.0;
  e.smallest_response = 0.0;  // a probe too small to move anything: named as such, never a ratio of -nan
  v = judge_probe_point(def, e);
  ASSERT_EQ(v.failed.size(), 1u);
  EXPECT_EQ(v.failed[0], "drifting");
  EXPECT_NE(v.reason.find("too small to measure"), std::string::npos) << v.reason;
  EXPECT_EQ(v.reason.find("nan"), std::string::npos) << v.reason;

  e = good_evidence();
  e.elastic_min_eigenvalue = -2.8e7;  // the review's negative diagonal at e1 = 3 %
  e.elastic_asymmetry = 0.98;
  v = judge_probe_point(def, e);
  ASSERT_EQ(v.failed.size(), 2u);
  EXPECT_EQ(v.failed[0], "elastic not positive definite");
  EXPECT_EQ(v.failed[1], "elastic asymmetric");

  e = good_evidence();
  e.elastic_factor = 3.01;
  EXPECT_TRUE(names(judge_probe_point(def, e), "elastic mismatch"));
  e.elastic_factor = INFINITY;  // turned more than 60 deg (the review's opposite sign)
  EXPECT_TRUE(names(judge_probe_point(def, e), "elastic mismatch"));
  e = good_evidence();
  e.elastic_check_missing = "the elastic check's probe e11 did not run or hold its control";
  EXPECT_TRUE(names(judge_probe_point(def, e), "elastic mismatch"));

  // A non-finite ratio is a failure, never a pass: NaN drift against a response of 0.
  e = good_evidence();
  e.smallest_response = 0.0;
  EXPECT_TRUE(names(judge_probe_point(def, e), "drifting"));

  // Every failure at once: all five, in kProbeCheckNames order; the status is the first.
  e.rest_reached = false;
  e.elastic_min_eigenvalue = -1.0;
  e.elastic_asymmetry = 0.5;
  e.elastic_factor = 10.0;
  v = judge_probe_point(def, e);
  ASSERT_EQ(v.failed.size(), kProbeCheckNames.size());
  for (std::size_t k = 0; k < v.failed.size(); ++k) EXPECT_EQ(v.failed[k], kProbeCheckNames[k]);
}

TEST(ProbeJudgement, LimitsComeFromTheDeck) {
  ProbeDef def = stress_probes(ProbePlane::Rendulic, 8);
  def.elastic_factor = 1.2;
  def.drift_limit = 0.001;
  def.asymmetry_limit = 0.005;
  const ProbeVerdict v = judge_probe_point(def, good_evidence());
  EXPECT_TRUE(names(v, "drifting") && names(v, "elastic asymmetric") && names(v, "elastic mismatch")) << v.reason;
}

TEST(ProbeJudgement, ElasticAgreementIsALengthRatioWithinSixtyDegrees) {
  const std::array<double, 6> p = {1e-5, -5e-6, -5e-6, 0, 0, 0};
  EXPECT_DOUBLE_EQ(elastic_agreement(p, p), 1.0);
  std::array<double, 6> a = p;
  for (double& x : a) x *= 3.0;
  EXPECT_NEAR(elastic_agreement(a, p), 3.0, 1e-12);
  EXPECT_NEAR(elastic_agreement(p, a), 3.0, 1e-12);  // either way
  for (double& x : a) x = -x;  // opposite sign: the review's de1 -2.06e-4 against +9.5e-6
  EXPECT_TRUE(std::isinf(elastic_agreement(a, p)));
  const std::array<double, 6> q = {1e-5, 1e-5, 0, 0, 0, 0}, r = {0, 1e-5, 1e-5, 0, 0, 0};  // 60 deg: still compared
  EXPECT_NEAR(elastic_agreement(q, r), 1.0, 1e-12);
  const std::array<double, 6> t = {1e-5, 0, 0, 0, 0, 0}, u = {0, 1e-5, 0, 0, 0, 0};  // 90 deg
  EXPECT_TRUE(std::isinf(elastic_agreement(t, u)));
  EXPECT_TRUE(std::isinf(elastic_agreement({}, p)));
}

TEST(ProbeJudgement, ConesFollowTheStressRatio) {
  const Vec3 s(300e3, 100e3, 100e3);  // a TTC state, s11/s33 = 3
  EXPECT_EQ(probe_cone({1, 0, 0, 0, 0, 0}, s), 1);     // raises s11
  EXPECT_EQ(probe_cone({-1, 0, 0, 0, 0, 0}, s), -1);
  EXPECT_EQ(probe_cone({0, 0.7, 0.7, 0, 0, 0}, s), -1);  // raises the confinement
  EXPECT_EQ(probe_cone({0.9486832980505138, 0, 0.31622776601683794, 0, 0, 0}, s), 0);  // along s: neutral
}

}  // namespace
}  // namespace celldem
