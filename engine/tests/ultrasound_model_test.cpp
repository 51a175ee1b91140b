#include "sensors/ultrasound_model.h"

#include <gtest/gtest.h>

#include <cmath>
#include <numbers>

#include "physics/particle_model.h"

using namespace cressim;
using namespace cressim::scene;

namespace {

UltrasoundProbe linear_probe() {
  UltrasoundProbe p;
  p.kind = ProbeKind::LINEAR;
  p.scanlines = 96, p.line_spacing = 0.006f, p.line_length = 0.7f, p.width = 130, p.height = 160;
  p.center_frequency = 3.5e6f, p.fractional_bandwidth = 0.6f, p.sampling_frequency = 40e6f;
  p.radial_decimation = 8, p.metres_per_unit = 0.1f;
  return p;
}

sensors::UltrasoundModel model(const World& w) {
  const auto mapping = build_layout_mapping(w);
  return sensors::build_ultrasound_model(w, mapping, physics::build_particle_model(w, mapping));
}

}  // namespace

TEST(UltrasoundModel, ProbePulseAndGeometryFollowThePhysics) {
  World w(SceneLayout{1});
  EntityId e = w.create_entity(0, "probe");
  w.add(e, linear_probe());
  auto m = model(w);
  ASSERT_EQ(m.probes.size(), 1u);
  const auto& d = m.probes[0];
  const double dz = 1540.0 / (2 * 40e6) * 8 / 0.1;  // scene units per IQ sample
  const double sigma_t = 1 / (2 * std::numbers::pi * 0.6 * 3.5e6 / 2.35482);
  EXPECT_NEAR(d.pulse.x, dz, 1e-7);
  EXPECT_NEAR(d.pulse.y, 1540.0 * sigma_t / 2 / 0.1, 1e-6);
  EXPECT_NEAR(d.pulse.z, 2 * 2 * std::numbers::pi * 3.5e6 / 1540 * 0.1, 1e-2);
  ASSERT_EQ(m.groups.size(), 1u);
  EXPECT_EQ(m.groups[0].samples, uint32_t(std::ceil(0.7 / dz)));
  EXPECT_NEAR(d.geometry.w, -47.5f * 0.006f, 1e-6);  // line 0 at -x, lines centred
  EXPECT_NEAR(d.image.z * 130, 96 * 0.006f, 1e-5);   // the image spans the lines
  EXPECT_EQ(d.ids.z, shader::PROBE_LINEAR);
}

TEST(UltrasoundModel, ScatterersFillTheRegionLessAnechoicInclusions) {
  World w(SceneLayout{2});
  for (uint32_t env : {0u, 1u}) {
    EntityId t = w.create_entity(env, "tissue");
    UltrasoundTissue tissue;
    tissue.size = {0.1f, 0.1f, 0.1f};
    tissue.density = 1e6f;  // 8000 in the box
    if (env == 1) tissue.inclusions.push_back({{0, 0, 0}, 0.05f, 0.0f});  // removes 4/3 pi 0.05^3 of 0.008
    w.add(t, tissue);
  }
  auto m = model(w);
  EXPECT_EQ(m.env_scatterers[0][1], 8000u);
  const double kept = 8000 * (1 - 4.0 / 3 * std::numbers::pi * 0.05 * 0.05 * 0.05 / 0.008);
  EXPECT_NEAR(double(m.env_scatterers[1][1]), kept, 4 * std::sqrt(kept));
  EXPECT_EQ(m.env_scatterers[1][0], 8000u);
  for (uint32_t i = 0; i < m.scatterers.size(); ++i) {
    const auto& s = m.scatterers[i];
    ASSERT_LE(std::max({std::abs(s.x), std::abs(s.y), std::abs(s.z)}), 0.1f);
    if (i >= 8000) ASSERT_GT(s.x * s.x + s.y * s.y + s.z * s.z, 0.05f * 0.05f);
    ASSERT_EQ(m.scatterer_carrier[i][0], i < 8000 ? 0u : 1u);  // each env's tissue row
  }
}

TEST(UltrasoundModel, ProbesOfOtherSizesFormGroupsOfTheirOwn) {
  World w(SceneLayout{3});
  w.add(w.create_entity(0, "a"), linear_probe());
  auto other = linear_probe();
  other.width = 64;
  w.add(w.create_entity(1, "b"), other);
  w.add(w.create_entity(2, "c"), linear_probe());
  auto m = model(w);
  ASSERT_EQ(m.groups.size(), 2u);
  EXPECT_EQ(m.probe_group, (std::vector<uint32_t>{0, 1, 0}));
  EXPECT_EQ(m.groups[0].layers, 2u);  // a and c share one set of outputs
  EXPECT_EQ(m.groups[1].width, 64u);
  EXPECT_EQ(m.probes[2].ids.w, 1u);  // c is its group's second layer
}

TEST(UltrasoundModel, SoftTissueScatterersFillItsTetsByBarycentricWeights) {
  World w(SceneLayout{1});
  EntityId e = w.create_entity(0, "liver");
  Transform t;
  t.scale = {2, 2, 2};  // the scene volume counts: 8 x (0.1)^3
  w.add(e, t);
  SoftBody sb;
  // one cube of 6 tets around the diagonal 0-7 (corners by bits x, y, z)
  for (int i = 0; i < 8; ++i) sb.positions.insert(sb.positions.end(), {0.1f * (i & 1), 0.1f * (i >> 1 & 1), 0.1f * (i >> 2 & 1)});
  sb.tets = {0, 1, 3, 7, 0, 3, 2, 7, 0, 2, 6, 7, 0, 6, 4, 7, 0, 4, 5, 7, 0, 5, 1, 7};
  w.add(e, sb);
  UltrasoundTissue tissue;
  tissue.density = 1e6f;
  w.add(e, tissue);
  auto m = model(w);
  ASSERT_EQ(m.tets.size(), 6u);
  EXPECT_NEAR(double(m.scatterers.size()), 8000.0, 4 * std::sqrt(8000.0));
  for (size_t i = 0; i < m.scatterers.size(); ++i) {
    const auto& s = m.scatterers[i];
    ASSERT_TRUE(m.scatterer_carrier[i][0] & shader::ULTRASOUND_TET_CARRIER);
    ASSERT_LT(m.scatterer_carrier[i][0] & ~shader::ULTRASOUND_TET_CARRIER, 6u);
    ASSERT_TRUE(s.x >= 0 && s.y >= 0 && s.z >= 0 && s.x + s.y + s.z <= 1.0001f);
  }
  EXPECT_FLOAT_EQ(m.tissue_attenuation[0], 0.5f);
}
