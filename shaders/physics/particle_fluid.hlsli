// SPH kernels of the fluid passes (Mueller et al. 2003; support h = 4 x particle radius):
// spiky for densities and their corrections (its gradient does not vanish near r = 0), poly6 for
// XSPH's smoothing, and Akinci et al. 2013's cohesion spline. Coefficients are worked out once
// per particle. The density and its correction must use the same kernel: with poly6 densities
// and spiky corrections (Macklin & Mueller 2013's choice) a correction is not along the gradient
// of the constraint it fixes, and a settled column never came to rest (0.08 m/s after 8 s).
static const float PI = 3.14159265358979;

struct Kernel {
  float h, h2, poly6, spiky, cohesion, cohesion_offset;
};

Kernel make_kernel(float radius) {
  Kernel k;
  k.h = 4 * radius;
  k.h2 = k.h * k.h;
  const float h3 = k.h2 * k.h, h6 = h3 * h3, h9 = h6 * h3;
  k.poly6 = 315.0 / (64.0 * PI * h9);
  k.spiky = -45.0 / (PI * h6);
  k.cohesion = 32.0 / (PI * h9);
  k.cohesion_offset = h6 / 64.0;
  return k;
}

float poly6(Kernel k, float r2) {
  if (r2 >= k.h2) return 0;
  const float x = k.h2 - r2;
  return k.poly6 * x * x * x;
}

// the spiky kernel, 15 / (pi h^6) (h - r)^3
float spiky(Kernel k, float r2) {
  if (r2 >= k.h2) return 0;
  const float x = k.h - sqrt(r2);
  return -k.spiky / 3 * x * x * x;
}

// gradient of the spiky kernel with respect to xi, for r = xi - xj (points from i toward j)
float3 spiky_gradient(Kernel k, float3 r) {
  const float r2 = dot(r, r);
  if (r2 >= k.h2 || r2 < 1e-18) return float3(0, 0, 0);
  const float len = sqrt(r2), x = k.h - len;
  return (k.spiky * x * x / len) * r;
}

float cohesion_spline(Kernel k, float r) {
  if (r >= k.h || r <= 0) return 0;
  const float a = (k.h - r) * (k.h - r) * (k.h - r) * r * r * r;
  return r > 0.5 * k.h ? k.cohesion * a : k.cohesion * (2 * a - k.cohesion_offset);
}

// mass of a particle (w is its inverse)
float particle_mass(float4 x) { return x.w > 0 ? 1.0 / x.w : 0; }

// fluid particle i's density correction from neighbour j (r = xi - xj), before the 1 / rho0:
// m_j (lambda_i + lambda_j) grad W_ij
float3 density_correction(Kernel K, float3 r, float4 xj, float lambda_i, float lambda_j) {
  return particle_mass(xj) * (lambda_i + lambda_j) * spiky_gradient(K, r);
}

// how near a wall (centre to surface) adds density to a fluid particle of radius r: beyond it the
// first lattice layer behind the wall (at d + r) is out of the kernel
float wall_reach(Kernel K, float r) { return K.h - r; }
