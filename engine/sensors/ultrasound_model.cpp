#include "sensors/ultrasound_model.h"

#include <algorithm>
#include <atomic>
#include <cmath>
#include <exception>
#include <map>
#include <numbers>
#include <random>
#include <stdexcept>
#include <string>
#include <thread>

#include "scene/authoring_error.h"

namespace cressim::sensors {
namespace {

constexpr float kFwhmPerSigma = 2.3548200f;  // 2 sqrt(2 ln 2)
constexpr float kReachSigmas = 3.0f;         // beam tails cut at 3 sigma (1 %)
// The pulse's tails cut at 4 sigma (3e-4): a cut kernel's spectrum has side lobes at the carrier,
// and at 3 sigma they alone would give a uniform tissue's echo a coherent part of 2e-3.
constexpr float kPulseReachSigmas = 4.0f;
// A scatterer's envelope is placed at its accumulator bin's centre while its phase keeps its
// exact depth. Binning at spacing b aliases the carrier: a uniform tissue's mean echo, which the
// pulse cancels (its spectrum at the two-way wavenumber 2k: exp(-(2k sigma_z)^2 / 2)), comes
// back as the spectrum at 2k - 2 pi / b. That mean grows with the scatterer count while the
// speckle grows with its square root, so the envelope turns Rician (SNR 3.3 at 100 scatterers
// per resolution cell with 8x-decimated IQ bins). Bins are made fine enough that
// (2 pi / b - 2k) sigma_z >= this, i.e. the alias is below exp(-8) = 3e-4 of the pulse's peak.
constexpr float kAliasSigmas = 4.0f;
constexpr uint32_t kMaxSamples = 1u << 16;   // per scanline

[[noreturn]] void fail(const scene::World& w, scene::EntityId e, const std::string& what) {
  throw scene::AuthoringError(w, e, what);
}

shader::UltrasoundProbeData probe_data(const scene::World& world, scene::EntityId e, uint32_t row, uint32_t env,
                                       uint32_t& samples) {
  const auto& p = world.get<scene::UltrasoundProbe>(e);
  shader::UltrasoundProbeData d{};
  const float n = float(p.scanlines), L = p.line_length;
  if (p.kind == scene::ProbeKind::LINEAR) {
    const float half = 0.5f * n * p.line_spacing;  // each line in the middle of its column
    d.geometry = {p.line_spacing, 0, L, -0.5f * (n - 1) * p.line_spacing};
    d.image = {-half, 0, 2 * half / float(p.width), L / float(p.height)};
  } else if (p.kind == scene::ProbeKind::SECTOR) {
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
  const float two_pi = 2 * std::numbers::pi_v<float>;
  const float per_sample = std::max(1.f, std::ceil(dz * (k2 + kAliasSigmas / sigma_z) / two_pi));
  if (double(samples) * per_sample > kMaxSamples)
    fail(world, e, "UltrasoundProbe needs " + std::to_string(uint64_t(samples * per_sample)) +
                       " bins per scanline (at most " + std::to_string(kMaxSamples) +
                       "): shorten line_length or widen fractional_bandwidth");
  const float bin = dz / per_sample;
  d.pulse = {dz, sigma_z, k2, std::ceil(kPulseReachSigmas * sigma_z / bin)};
  const float sl = p.lateral_beam_width / kFwhmPerSigma, se = p.elevational_beam_width / kFwhmPerSigma;
  d.beam = {sl, se, bin, per_sample};
  const float cm_per_unit = 100 * p.metres_per_unit;
  d.display = {p.dynamic_range, p.gain, p.time_gain_compensation * cm_per_unit, 0};
  // Gaussian beam: the two-way sigma is half the one-way 1/e^2 radius w0, and the width grows
  // as sqrt(1 + (distance from focus / z_R)^2) with z_R = pi w0^2 / wavelength
  const float wavelength = p.speed_of_sound / p.center_frequency / p.metres_per_unit;
  const float pi = std::numbers::pi_v<float>;
  d.depth = {p.focal_depth, pi * 4 * sl * sl / wavelength, pi * 4 * se * se / wavelength,
             2 * p.center_frequency * 1e-6f * cm_per_unit};
  d.specular = {p.specular_amplitude, p.coupling_impedance, 0, 0};
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

// Scatterers put in Morton order of 32^3 cells over their box (lo, extent): threads
// that run together then deposit to nearby accumulator bins, which keeps the atomics in cache.
// Sums are exact integers, so the order changes no image.
void sort_by_cell(std::vector<shader::float4>& s, const scene::Vec3& lo, const scene::Vec3& extent) {
  constexpr uint32_t kSide = 32;
  auto key = [&](const shader::float4& q) {
    const float p[3] = {q.x, q.y, q.z};
    uint32_t code = 0;
    for (int d = 0; d < 3; ++d) {
      const auto c = uint32_t(std::clamp((p[d] - lo[d]) / extent[d] * kSide, 0.f, float(kSide - 1)));
      for (uint32_t b = 0; b < 5; ++b) code |= ((c >> b) & 1u) << (3 * b + d);
    }
    return code;
  };
  std::vector<uint64_t> start(kSide * kSide * kSide + 1, 0);
  for (const auto& q : s) ++start[key(q) + 1];
  for (size_t k = 1; k < start.size(); ++k) start[k] += start[k - 1];
  std::vector<shader::float4> sorted(s.size());
  for (const auto& q : s) sorted[start[key(q)]++] = q;
  s.swap(sorted);
}

// rigid carrier: uniform in the region, in the entity frame (posed by the entity's row)
std::vector<shader::float4> generate(const scene::World& world, scene::EntityId e) {
  const auto& t = world.get<scene::UltrasoundTissue>(e);
  scene::Vec3 half = t.size;  // bounding box half extents of the region
  float volume = 0;
  const float pi = std::numbers::pi_v<float>;
  switch (t.region) {
    case scene::RegionKind::BOX: volume = 8 * half[0] * half[1] * half[2]; break;
    case scene::RegionKind::SPHERE: half = {t.size[0], t.size[0], t.size[0]}; volume = 4.f / 3 * pi * std::pow(t.size[0], 3.f); break;
    case scene::RegionKind::CYLINDER: half = {t.size[0], t.size[0], t.size[1]}; volume = pi * t.size[0] * t.size[0] * 2 * t.size[1]; break;
    default: break;  // validate_world() admits no other region
  }
  const double wanted = t.count > 0 ? double(t.count) : double(t.density) * volume;
  check_count(world, e, wanted);

  auto rng = seeded(t, e);
  std::uniform_real_distribution<float> uni(-1, 1);
  std::normal_distribution<float> amp(t.amplitude_mean, t.amplitude_std);
  std::vector<shader::float4> made;
  made.reserve(size_t(std::llround(wanted)));
  for (uint64_t drawn = 0; drawn < uint64_t(std::llround(wanted));) {
    const scene::Vec3 q{half[0] * uni(rng), half[1] * uni(rng), half[2] * uni(rng)};
    if (!inside(t, q)) continue;  // rejection keeps the density uniform in the region
    ++drawn;
    const scene::Vec3 p{t.center[0] + q[0], t.center[1] + q[1], t.center[2] + q[2]};
    const float a = amplitude(t, p, amp, rng);
    if (a == 0) continue;  // anechoic: nothing to trace
    made.push_back({p[0], p[1], p[2], a});
  }
  const scene::Vec3 lo{t.center[0] - half[0], t.center[1] - half[1], t.center[2] - half[2]};
  sort_by_cell(made, lo, {2 * half[0], 2 * half[1], 2 * half[2]});
  return made;
}

// every rigid tissue's scatterers (entities in row order), drawn on all cores: each tissue has
// its own random stream, so the result does not depend on the threads
std::map<scene::EntityId, std::vector<shader::float4>> generate_rigid(const scene::World& world,
                                                                      const scene::LayoutMapping& mapping) {
  std::vector<scene::EntityId> tissues;
  for (uint32_t row = 0; row < mapping.row_entity.size(); ++row) {
    const scene::EntityId e = mapping.row_entity[row];
    if (world.has<scene::UltrasoundTissue>(e) && !world.has<scene::SoftBody>(e)) tissues.push_back(e);
  }
  std::vector<std::vector<shader::float4>> made(tissues.size());
  std::vector<std::exception_ptr> errors(tissues.size());
  std::atomic<size_t> next{0};
  auto work = [&] {
    for (size_t i; (i = next++) < tissues.size();) {
      try {
        made[i] = generate(world, tissues[i]);
      } catch (...) {
        errors[i] = std::current_exception();
      }
    }
  };
  const size_t cores = std::max(1u, std::thread::hardware_concurrency());
  std::vector<std::thread> workers(std::min(cores, tissues.size()));
  for (auto& w : workers) w = std::thread(work);
  for (auto& w : workers) w.join();
  std::map<scene::EntityId, std::vector<shader::float4>> out;
  for (size_t i = 0; i < tissues.size(); ++i) {
    if (errors[i]) std::rethrow_exception(errors[i]);
    out[tissues[i]] = std::move(made[i]);
  }
  return out;
}

// the soft body's first particle in the particle model
uint32_t first_particle(const scene::World& world, scene::EntityId e, const physics::ParticleModel& particles) {
  for (size_t o = 0; o < particles.objects.size(); ++o)
    if (particles.object_entity[o] == e) return particles.objects[o].range.x;
  throw std::logic_error(world.describe(e) + ": its SoftBody is not in the particle model");
}

// soft carrier: each tet gets volume x density scatterers (the fraction drawn), uniform inside
// it by barycentric weights (sorted uniforms: uniform on the simplex); inclusions are judged
// at the rest position in the entity frame, so they deform with the tets
void generate_in_tets(const scene::World& world, scene::EntityId e, const physics::ParticleModel& particles,
                      uint32_t tissue, UltrasoundModel& m) {
  const auto& t = world.get<scene::UltrasoundTissue>(e);
  const auto& sb = world.get<scene::SoftBody>(e);
  const uint32_t first = first_particle(world, e, particles);
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

// meshfree carrier (a SoftBody without tets): the tissue is the union of the cubes of side s
// (the median nearest-neighbour spacing) centred on the particles at rest, filled at the
// tissue's density by rejection sampling in its bounds. Each scatterer rides on four of its
// nearest particles that span a volume (affine weights, negative outside their tetrahedron), so
// it follows the particles' local affine motion; scatterers with the same four share one entry
// of the tet table. Inclusions are judged at the rest position, as for tets.
void generate_in_particles(const scene::World& world, scene::EntityId e, const physics::ParticleModel& particles,
                           uint32_t tissue, UltrasoundModel& m) {
  const auto& t = world.get<scene::UltrasoundTissue>(e);
  const auto& sb = world.get<scene::SoftBody>(e);
  const uint32_t first = first_particle(world, e, particles), n = uint32_t(sb.positions.size() / 3);
  if (n < 4) fail(world, e, "UltrasoundTissue on a meshfree SoftBody needs at least 4 particles");
  const scene::Transform tf = world.has<scene::Transform>(e) ? world.get<scene::Transform>(e) : scene::Transform{};
  using V = std::array<double, 3>;
  std::vector<V> x(n);
  V lo{1e300, 1e300, 1e300}, hi{-1e300, -1e300, -1e300};
  for (uint32_t i = 0; i < n; ++i)
    for (int d = 0; d < 3; ++d) {
      x[i][d] = sb.positions[3 * i + d];
      lo[d] = std::min(lo[d], x[i][d]), hi[d] = std::max(hi[d], x[i][d]);
    }
  auto dist2 = [](const V& a, const V& b) {
    return (a[0] - b[0]) * (a[0] - b[0]) + (a[1] - b[1]) * (a[1] - b[1]) + (a[2] - b[2]) * (a[2] - b[2]);
  };
  // a grid of cell s over the particles: the spacing first (brute force over a sample is enough
  // for a median), then neighbour lookups
  std::vector<double> nearest;
  for (uint32_t i = 0; i < n; i += std::max<uint32_t>(1, n / 256)) {
    double best = 1e300;
    for (uint32_t j = 0; j < n; ++j)
      if (j != i) best = std::min(best, dist2(x[i], x[j]));
    nearest.push_back(std::sqrt(best));
  }
  std::nth_element(nearest.begin(), nearest.begin() + nearest.size() / 2, nearest.end());
  const double s = nearest[nearest.size() / 2];
  if (!(s > 0)) fail(world, e, "UltrasoundTissue on a meshfree SoftBody: particles coincide");
  for (int d = 0; d < 3; ++d) lo[d] -= s / 2, hi[d] += s / 2;
  int dims[3];
  for (int d = 0; d < 3; ++d) dims[d] = std::max(1, int(std::ceil((hi[d] - lo[d]) / s)));
  auto cell_of = [&](const V& p, int d) { return std::clamp(int((p[d] - lo[d]) / s), 0, dims[d] - 1); };
  std::vector<std::vector<uint32_t>> cells(size_t(dims[0]) * dims[1] * dims[2]);
  for (uint32_t i = 0; i < n; ++i)
    cells[(size_t(cell_of(x[i], 2)) * dims[1] + cell_of(x[i], 1)) * dims[0] + cell_of(x[i], 0)].push_back(i);
  // particles within two cells of p, nearest first
  auto around = [&](const V& p) {
    std::vector<std::pair<double, uint32_t>> near;
    const int c[3] = {cell_of(p, 0), cell_of(p, 1), cell_of(p, 2)};
    for (int k = std::max(0, c[2] - 2); k <= std::min(dims[2] - 1, c[2] + 2); ++k)
      for (int j = std::max(0, c[1] - 2); j <= std::min(dims[1] - 1, c[1] + 2); ++j)
        for (int i = std::max(0, c[0] - 2); i <= std::min(dims[0] - 1, c[0] + 2); ++i)
          for (uint32_t q : cells[(size_t(k) * dims[1] + j) * dims[0] + i]) near.push_back({dist2(p, x[q]), q});
    std::sort(near.begin(), near.end());
    return near;
  };
  auto sub = [](const V& a, const V& b) { return V{a[0] - b[0], a[1] - b[1], a[2] - b[2]}; };
  auto cross = [](const V& a, const V& b) {
    return V{a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]};
  };
  auto dot = [](const V& a, const V& b) { return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]; };

  // scatterers: the tissue's count, or density x volume (scale applies, as to the particles)
  const double box = (hi[0] - lo[0]) * (hi[1] - lo[1]) * (hi[2] - lo[2]);
  const double scaled = std::abs(double(tf.scale[0]) * tf.scale[1] * tf.scale[2]);
  const double inside_estimate = std::min(box, double(n) * s * s * s);
  const double wanted = t.count > 0 ? double(t.count) : double(t.density) * inside_estimate * scaled;
  check_count(world, e, wanted);
  auto rng = seeded(t, e);
  std::uniform_real_distribution<double> uni(0, 1);
  std::normal_distribution<float> amp(t.amplitude_mean, t.amplitude_std);
  std::map<std::array<uint32_t, 4>, uint32_t> frames;
  // by count: draw until that many land inside; by density: the box's worth of draws, the
  // inside ones kept (so the count follows the true volume, not the estimate)
  const uint64_t draws = t.count > 0 ? UINT64_MAX : uint64_t(std::llround(double(t.density) * box * scaled));
  uint64_t kept = 0;
  for (uint64_t k = 0; k < draws && (t.count == 0 || kept < t.count); ++k) {
    if (t.count > 0 && k > 1000 * uint64_t(t.count) + 1000000)
      fail(world, e, "UltrasoundTissue on a meshfree SoftBody: too few draws land in the tissue");
    const V p{lo[0] + uni(rng) * (hi[0] - lo[0]), lo[1] + uni(rng) * (hi[1] - lo[1]), lo[2] + uni(rng) * (hi[2] - lo[2])};
    const auto near = around(p);
    if (near.empty()) continue;
    const V& c = x[near[0].second];
    if (std::abs(p[0] - c[0]) > s / 2 || std::abs(p[1] - c[1]) > s / 2 || std::abs(p[2] - c[2]) > s / 2) continue;
    // four nearest that span a volume: a second, a third off their line, a fourth off their plane
    std::array<uint32_t, 4> f{near[0].second, UINT32_MAX, UINT32_MAX, UINT32_MAX};
    const double tiny = 1e-3 * s;
    for (size_t q = 1; q < near.size() && f[3] == UINT32_MAX; ++q) {
      const uint32_t id = near[q].second;
      const V d = sub(x[id], x[f[0]]);
      if (f[1] == UINT32_MAX) {
        f[1] = id;
      } else if (f[2] == UINT32_MAX) {
        if (std::sqrt(dot(cross(sub(x[f[1]], x[f[0]]), d), cross(sub(x[f[1]], x[f[0]]), d))) > tiny * s) f[2] = id;
      } else if (std::abs(dot(cross(sub(x[f[1]], x[f[0]]), sub(x[f[2]], x[f[0]])), d)) > tiny * s * s) {
        f[3] = id;
      }
    }
    if (f[3] == UINT32_MAX) fail(world, e, "UltrasoundTissue on a meshfree SoftBody: particles near (" +
                                               std::to_string(p[0]) + ", " + std::to_string(p[1]) + ", " +
                                               std::to_string(p[2]) + ") all lie in one plane");
    // affine weights of p in the frame (x1 - x0, x2 - x0, x3 - x0): Cramer's rule
    const V a = sub(x[f[1]], x[f[0]]), b = sub(x[f[2]], x[f[0]]), cc = sub(x[f[3]], x[f[0]]), r = sub(p, x[f[0]]);
    const double det = dot(a, cross(b, cc));
    const float w[3] = {float(dot(r, cross(b, cc)) / det), float(dot(a, cross(r, cc)) / det),
                        float(dot(a, cross(b, r)) / det)};
    const float ampl = amplitude(t, scene::Vec3{float(p[0]), float(p[1]), float(p[2])}, amp, rng);
    ++kept;
    if (ampl == 0) continue;
    auto [it, added] = frames.try_emplace(f, uint32_t(m.tets.size()));
    if (added) {
      if (m.tets.size() + 1 >= shader::ULTRASOUND_TET_CARRIER) throw std::invalid_argument("more than 2^31 ultrasound tets");
      m.tets.push_back({first + f[0], first + f[1], first + f[2], first + f[3]});
    }
    m.scatterers.push_back({w[0], w[1], w[2], ampl});
    m.scatterer_carrier.push_back({it->second | shader::ULTRASOUND_TET_CARRIER, tissue});
  }
}

}  // namespace

UltrasoundModel build_ultrasound_model(const scene::World& world, const scene::LayoutMapping& mapping,
                                       const physics::ParticleModel& particles) {
  UltrasoundModel m;
  m.env_scatterers.assign(mapping.num_envs, {0, 0});
  auto rigid = generate_rigid(world, mapping);
  static_assert(uint32_t(scene::RegionKind::BOX) == shader::ULTRASOUND_BOX &&
                uint32_t(scene::RegionKind::SPHERE) == shader::ULTRASOUND_SPHERE &&
                uint32_t(scene::RegionKind::CYLINDER) == shader::ULTRASOUND_CYLINDER);
  for (uint32_t env = 0; env < mapping.num_envs; ++env) {
    const uint32_t first = uint32_t(m.scatterers.size());
    const uint32_t env_media = uint32_t(m.media.size()), env_probes = uint32_t(m.probes.size());
    for (uint32_t row = mapping.env_offset[env]; row < mapping.env_offset[env] + mapping.env_count[env]; ++row) {
      const scene::EntityId e = mapping.row_entity[row];
      if (world.has<scene::UltrasoundTissue>(e)) {
        const auto& t = world.get<scene::UltrasoundTissue>(e);
        const uint32_t tissue = uint32_t(m.tissue_attenuation.size());
        m.tissue_attenuation.push_back(t.attenuation);
        if (!world.has<scene::SoftBody>(e)) {
          auto& made = rigid.at(e);
          m.scatterers.insert(m.scatterers.end(), made.begin(), made.end());
          m.scatterer_carrier.insert(m.scatterer_carrier.end(), made.size(), {row, tissue});
          std::vector<shader::float4>().swap(made);
          m.media.push_back({{row, uint32_t(t.region), 0, 0}, {t.center[0], t.center[1], t.center[2], t.impedance},
                             {t.size[0], t.size[1], t.size[2], t.attenuation}});
        } else if (world.get<scene::SoftBody>(e).tets.empty()) generate_in_particles(world, e, particles, tissue, m);
        else generate_in_tets(world, e, particles, tissue, m);
      }
      if (!world.has<scene::UltrasoundProbe>(e)) continue;
      uint32_t samples = 0;
      auto d = probe_data(world, e, row, env, samples);
      const auto& p = world.get<scene::UltrasoundProbe>(e);
      const uint32_t rf = p.rf_output ? p.radial_decimation : 0;
      uint32_t g = 0;
      for (; g < m.groups.size(); ++g) {
        const auto& o = m.groups[g];
        if (o.lines == p.scanlines && o.samples == samples && o.width == p.width && o.height == p.height &&
            o.rf_factor == rf)
          break;
      }
      if (g == m.groups.size()) m.groups.push_back({p.scanlines, samples, p.width, p.height, 0, rf, 0});
      auto& group = m.groups[g];
      group.bins = std::max(group.bins, samples * uint32_t(d.beam.w));
      d.ids.w = group.layers++;
      m.probes.push_back(d);
      m.probe_group.push_back(g);
      m.probe_entity.push_back(e);
    }
    for (uint32_t probe = env_probes; probe < m.probes.size(); ++probe)
      m.probes[probe].media = {env_media, uint32_t(m.media.size()) - env_media, 0, 0};
    const uint64_t count = m.scatterers.size() - first;
    if (m.scatterers.size() > UINT32_MAX)
      throw std::invalid_argument("env " + std::to_string(env) + ": the world's ultrasound tissues reach " +
                                  std::to_string(m.scatterers.size()) + " scatterers (at most 2^32 - 1 in all envs)");
    m.env_scatterers[env] = {first, uint32_t(count)};
  }
  return m;
}

}  // namespace cressim::sensors
