#include "sensors/ultrasound_model.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>

namespace cressim::sensors {
namespace {

constexpr float kFwhmPerSigma = 2.3548200f;  // 2 sqrt(2 ln 2)
constexpr float kReachSigmas = 3.0f;         // beam and pulse tails cut at 3 sigma (1 %)
constexpr uint32_t kMaxSamples = 1u << 16;   // per scanline

[[noreturn]] void fail(const scene::World& w, scene::EntityId e, const std::string& what) {
  throw std::invalid_argument(w.describe(e) + ": " + what);
}

shader::UltrasoundProbeData probe_data(const scene::World& world, scene::EntityId e, uint32_t row, uint32_t env,
                                       uint32_t& samples) {
  const auto& p = world.get<scene::UltrasoundProbe>(e);
  auto positive = [&](float v, const char* field) {
    if (!(v > 0) || !std::isfinite(v)) fail(world, e, std::string("UltrasoundProbe.") + field + " must be positive");
  };
  positive(p.line_length, "line_length");
  positive(p.sampling_frequency, "sampling_frequency");
  positive(p.center_frequency, "center_frequency");
  positive(p.fractional_bandwidth, "fractional_bandwidth");
  positive(p.lateral_beam_width, "lateral_beam_width");
  positive(p.elevational_beam_width, "elevational_beam_width");
  positive(p.speed_of_sound, "speed_of_sound");
  positive(p.metres_per_unit, "metres_per_unit");
  positive(p.dynamic_range, "dynamic_range");
  if (p.width == 0 || p.height == 0) fail(world, e, "UltrasoundProbe.width and height must be positive");
  if (p.radial_decimation == 0) fail(world, e, "UltrasoundProbe.radial_decimation must be at least 1");

  shader::UltrasoundProbeData d{};
  const float n = float(p.scanlines), L = p.line_length;
  if (p.kind == scene::ProbeKind::LINEAR) {
    if (p.scanlines < 1) fail(world, e, "UltrasoundProbe.scanlines must be at least 1");
    positive(p.line_spacing, "line_spacing");
    const float half = 0.5f * n * p.line_spacing;  // each line in the middle of its column
    d.geometry = {p.line_spacing, 0, L, -0.5f * (n - 1) * p.line_spacing};
    d.image = {-half, 0, 2 * half / float(p.width), L / float(p.height)};
  } else if (p.kind == scene::ProbeKind::SECTOR) {
    if (p.scanlines < 2) fail(world, e, "UltrasoundProbe.scanlines must be at least 2 for a sector probe");
    if (!(p.sector_angle > 0 && p.sector_angle < 180)) fail(world, e, "UltrasoundProbe.sector_angle must be in (0, 180) degrees");
    if (!(p.radius >= 0)) fail(world, e, "UltrasoundProbe.radius must not be negative");
    const float a = p.sector_angle * std::numbers::pi_v<float> / 180, R = p.radius;
    const float half = (R + L) * std::sin(0.5f * a), top = R * std::cos(0.5f * a) - R;
    d.geometry = {a / (n - 1), R, L, -0.5f * a};
    d.image = {-half, top, 2 * half / float(p.width), (L - top) / float(p.height)};
  } else {
    fail(world, e, "UltrasoundProbe.kind must be linear or sector");
  }
  // RF sampled at fs, decimated; the pulse's Gaussian envelope from its -6 dB bandwidth
  const float dz = p.speed_of_sound / (2 * p.sampling_frequency) * float(p.radial_decimation) / p.metres_per_unit;
  const float sigma_f = p.fractional_bandwidth * p.center_frequency / kFwhmPerSigma;
  const float sigma_t = 1 / (2 * std::numbers::pi_v<float> * sigma_f);
  const float sigma_z = p.speed_of_sound * sigma_t / 2 / p.metres_per_unit;
  const float k2 = 2 * 2 * std::numbers::pi_v<float> * p.center_frequency / p.speed_of_sound * p.metres_per_unit;
  const double count = std::ceil(double(L) / dz);
  if (count > kMaxSamples)
    fail(world, e, "UltrasoundProbe gives " + std::to_string(uint64_t(count)) + " IQ samples per scanline (at most " +
                       std::to_string(kMaxSamples) + "): raise radial_decimation or shorten line_length");
  samples = uint32_t(count);
  d.pulse = {dz, sigma_z, k2, std::ceil(kReachSigmas * sigma_z / dz)};
  const float sl = p.lateral_beam_width / kFwhmPerSigma, se = p.elevational_beam_width / kFwhmPerSigma;
  d.beam = {sl, se, 0, 0};
  if (!std::isfinite(p.time_gain_compensation)) fail(world, e, "UltrasoundProbe.time_gain_compensation must be finite");
  if (!(p.focal_depth >= 0) || !std::isfinite(p.focal_depth)) fail(world, e, "UltrasoundProbe.focal_depth must be >= 0");
  const float cm_per_unit = 100 * p.metres_per_unit;
  d.display = {p.dynamic_range, p.gain, p.time_gain_compensation * cm_per_unit, 0};
  // Gaussian beam: the two-way sigma is half the one-way 1/e^2 radius w0, and the width grows
  // as sqrt(1 + (distance from focus / z_R)^2) with z_R = pi w0^2 / wavelength
  const float wavelength = p.speed_of_sound / p.center_frequency / p.metres_per_unit;
  const float pi = std::numbers::pi_v<float>;
  d.depth = {p.focal_depth, pi * 4 * sl * sl / wavelength, pi * 4 * se * se / wavelength,
             2 * p.center_frequency * 1e-6f * cm_per_unit};
  d.ids = {row, env, uint32_t(p.kind), 0};
  return d;
}

bool inside(const scene::UltrasoundTissue& t, const scene::Vec3& q) {  // q relative to the region centre
  switch (t.region) {
    case scene::RegionKind::SPHERE: return q[0] * q[0] + q[1] * q[1] + q[2] * q[2] <= t.size[0] * t.size[0];
    case scene::RegionKind::CYLINDER: return q[0] * q[0] + q[1] * q[1] <= t.size[0] * t.size[0];
    default: return true;
  }
}

// the tissue's fields that do not depend on its carrier
void check(const scene::World& world, scene::EntityId e, const scene::UltrasoundTissue& t) {
  if ((t.density > 0) == (t.count > 0)) fail(world, e, "UltrasoundTissue: give either density or count (> 0)");
  if (!(t.amplitude_std >= 0)) fail(world, e, "UltrasoundTissue.amplitude_std must not be negative");
  if (!(t.attenuation >= 0) || !std::isfinite(t.attenuation))
    fail(world, e, "UltrasoundTissue.attenuation must be >= 0 (dB/cm/MHz)");
  for (const auto& inc : t.inclusions)
    if (!(inc.radius > 0) || !(inc.amplitude_scale >= 0))
      fail(world, e, "UltrasoundTissue inclusions need radius > 0 and amplitude_scale >= 0");
}

void check_count(const scene::World& world, scene::EntityId e, double wanted) {
  if (wanted > 2e9) fail(world, e, "UltrasoundTissue asks for " + std::to_string(wanted) + " scatterers");
}

// a scatterer's amplitude at p in the tissue's (rest) entity frame: its inclusions scale it
float amplitude(const scene::UltrasoundTissue& t, const scene::Vec3& p, std::normal_distribution<float>& amp,
                std::mt19937_64& rng) {
  float a = amp(rng);
  for (const auto& inc : t.inclusions) {
    const float dx = p[0] - inc.center[0], dy = p[1] - inc.center[1], dz = p[2] - inc.center[2];
    if (dx * dx + dy * dy + dz * dz <= inc.radius * inc.radius) a *= inc.amplitude_scale;
  }
  return a;
}

std::mt19937_64 seeded(const scene::UltrasoundTissue& t, scene::EntityId e) {
  return std::mt19937_64(uint64_t(t.seed) * 0x9E3779B97F4A7C15ull + e + 1);
}

// rigid carrier: uniform in the region, in the entity frame, posed by the entity's row
void generate(const scene::World& world, scene::EntityId e, uint32_t row, uint32_t tissue, UltrasoundModel& m) {
  const auto& t = world.get<scene::UltrasoundTissue>(e);
  scene::Vec3 half = t.size;  // bounding box half extents of the region
  float volume = 0;
  const float pi = std::numbers::pi_v<float>;
  switch (t.region) {
    case scene::RegionKind::BOX: volume = 8 * half[0] * half[1] * half[2]; break;
    case scene::RegionKind::SPHERE: half = {t.size[0], t.size[0], t.size[0]}; volume = 4.f / 3 * pi * std::pow(t.size[0], 3.f); break;
    case scene::RegionKind::CYLINDER: half = {t.size[0], t.size[0], t.size[1]}; volume = pi * t.size[0] * t.size[0] * 2 * t.size[1]; break;
    default: fail(world, e, "UltrasoundTissue.region must be box, sphere or cylinder");
  }
  if (!(volume > 0)) fail(world, e, "UltrasoundTissue.size must be positive");
  const double wanted = t.count > 0 ? double(t.count) : double(t.density) * volume;
  check_count(world, e, wanted);

  auto rng = seeded(t, e);
  std::uniform_real_distribution<float> uni(-1, 1);
  std::normal_distribution<float> amp(t.amplitude_mean, t.amplitude_std);
  for (uint64_t made = 0; made < uint64_t(std::llround(wanted));) {
    const scene::Vec3 q{half[0] * uni(rng), half[1] * uni(rng), half[2] * uni(rng)};
    if (!inside(t, q)) continue;  // rejection keeps the density uniform in the region
    ++made;
    const scene::Vec3 p{t.center[0] + q[0], t.center[1] + q[1], t.center[2] + q[2]};
    const float a = amplitude(t, p, amp, rng);
    if (a == 0) continue;  // anechoic: nothing to trace
    m.scatterers.push_back({p[0], p[1], p[2], a});
    m.scatterer_carrier.push_back({row, tissue});
  }
}

// soft carrier: each tet gets volume x density scatterers (the fraction drawn), uniform inside
// it by barycentric weights (sorted uniforms: uniform on the simplex); inclusions are judged
// at the rest position in the entity frame, so they deform with the tets
void generate_in_tets(const scene::World& world, scene::EntityId e, const physics::ParticleModel& particles,
                      uint32_t tissue, UltrasoundModel& m) {
  const auto& t = world.get<scene::UltrasoundTissue>(e);
  const auto& sb = world.get<scene::SoftBody>(e);
  if (sb.tets.empty())
    fail(world, e, "UltrasoundTissue on a SoftBody without tets: scatterers ride on tets (give the SoftBody a TetMesh)");
  uint32_t first = UINT32_MAX;
  for (size_t o = 0; o < particles.objects.size(); ++o)
    if (particles.object_entity[o] == e) first = particles.objects[o].range.x;
  if (first == UINT32_MAX) throw std::logic_error(world.describe(e) + ": its SoftBody is not in the particle model");
  const scene::Transform tf = world.has<scene::Transform>(e) ? world.get<scene::Transform>(e) : scene::Transform{};
  auto local = [&](uint32_t v) {
    return scene::Vec3{sb.positions[3 * v], sb.positions[3 * v + 1], sb.positions[3 * v + 2]};
  };
  const size_t count = sb.tets.size() / 4;
  std::vector<double> volume(count);
  double total = 0;
  for (size_t k = 0; k < count; ++k) {  // in the scene (scale applies, as to the particles)
    scene::Vec3 q[4];
    for (int i = 0; i < 4; ++i) {
      q[i] = local(sb.tets[4 * k + i]);
      for (int j = 0; j < 3; ++j) q[i][j] *= tf.scale[j];
    }
    const double a[3] = {q[1][0] - q[0][0], q[1][1] - q[0][1], q[1][2] - q[0][2]};
    const double b[3] = {q[2][0] - q[0][0], q[2][1] - q[0][1], q[2][2] - q[0][2]};
    const double c[3] = {q[3][0] - q[0][0], q[3][1] - q[0][1], q[3][2] - q[0][2]};
    volume[k] = std::abs(a[0] * (b[1] * c[2] - b[2] * c[1]) - a[1] * (b[0] * c[2] - b[2] * c[0]) +
                         a[2] * (b[0] * c[1] - b[1] * c[0])) / 6;
    total += volume[k];
  }
  const double per_volume = t.count > 0 ? double(t.count) / total : double(t.density);
  check_count(world, e, per_volume * total);
  if (m.tets.size() + count > shader::ULTRASOUND_TET_CARRIER) throw std::invalid_argument("more than 2^31 ultrasound tets");

  auto rng = seeded(t, e);
  std::uniform_real_distribution<float> uni(0, 1);
  std::normal_distribution<float> amp(t.amplitude_mean, t.amplitude_std);
  for (size_t k = 0; k < count; ++k) {
    const uint32_t* v = &sb.tets[4 * k];
    const uint32_t tet = uint32_t(m.tets.size());
    m.tets.push_back({first + v[0], first + v[1], first + v[2], first + v[3]});
    const double expected = per_volume * volume[k];
    uint64_t n = uint64_t(expected);
    if (uni(rng) < expected - double(n)) ++n;
    for (uint64_t i = 0; i < n; ++i) {
      float u[3] = {uni(rng), uni(rng), uni(rng)};
      std::sort(u, u + 3);
      const float w[4] = {1 - u[2], u[0], u[1] - u[0], u[2] - u[1]};
      scene::Vec3 p{0, 0, 0};
      for (int j = 0; j < 4; ++j) {
        const auto q = local(v[j]);
        for (int d = 0; d < 3; ++d) p[d] += w[j] * q[d];
      }
      const float a = amplitude(t, p, amp, rng);
      if (a == 0) continue;
      m.scatterers.push_back({w[1], w[2], w[3], a});
      m.scatterer_carrier.push_back({tet | shader::ULTRASOUND_TET_CARRIER, tissue});
    }
  }
}

}  // namespace

UltrasoundModel build_ultrasound_model(const scene::World& world, const scene::LayoutMapping& mapping,
                                       const physics::ParticleModel& particles) {
  UltrasoundModel m;
  m.env_scatterers.assign(mapping.num_envs, {0, 0});
  for (uint32_t env = 0; env < mapping.num_envs; ++env) {
    const uint32_t first = uint32_t(m.scatterers.size());
    for (uint32_t row = mapping.env_offset[env]; row < mapping.env_offset[env] + mapping.env_count[env]; ++row) {
      const scene::EntityId e = mapping.row_entity[row];
      if (world.has<scene::UltrasoundTissue>(e)) {
        const auto& t = world.get<scene::UltrasoundTissue>(e);
        check(world, e, t);
        const uint32_t tissue = uint32_t(m.tissue_attenuation.size());
        m.tissue_attenuation.push_back(t.attenuation);
        if (world.has<scene::SoftBody>(e)) generate_in_tets(world, e, particles, tissue, m);
        else generate(world, e, row, tissue, m);
      }
      if (!world.has<scene::UltrasoundProbe>(e)) continue;
      uint32_t samples = 0;
      auto d = probe_data(world, e, row, env, samples);
      const auto& p = world.get<scene::UltrasoundProbe>(e);
      const uint32_t rf = p.rf_output ? p.radial_decimation : 0;
      if (m.probes.empty()) {
        m.lines = p.scanlines, m.samples = samples, m.width = p.width, m.height = p.height, m.rf_factor = rf;
      } else if (m.lines != p.scanlines || m.samples != samples || m.width != p.width || m.height != p.height) {
        fail(world, e, "every UltrasoundProbe of a world must have the same scanlines, image size and samples per "
                       "line (" + std::to_string(m.lines) + " lines, " + std::to_string(m.width) + "x" +
                       std::to_string(m.height) + ", " + std::to_string(m.samples) + " samples) for now");
      } else if (m.rf_factor != rf) {
        fail(world, e, "UltrasoundProbe.rf_output: every probe of a world asks for RF, with one radial_decimation, "
                       "or none does");
      }
      d.ids.w = uint32_t(m.probes.size());
      m.probes.push_back(d);
      m.probe_entity.push_back(e);
    }
    const uint64_t count = m.scatterers.size() - first;
    if (m.scatterers.size() > UINT32_MAX) throw std::invalid_argument("more than 2^32 ultrasound scatterers");
    m.env_scatterers[env] = {first, uint32_t(count)};
    m.max_env_scatterers = std::max(m.max_env_scatterers, uint32_t(count));
  }
  return m;
}

}  // namespace cressim::sensors
