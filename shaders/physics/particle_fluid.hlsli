// SPH kernels of the fluid passes (Mueller et al. 2003; support h = 4 x particle radius):
// poly6 for densities, spiky's gradient for corrections (it does not vanish near r = 0), and
// Akinci et al. 2013's cohesion spline.
static const float PI = 3.14159265358979;

float kernel_support(float radius) { return 4 * radius; }

float poly6(float r, float h) {
  if (r >= h) return 0;
  const float x = h * h - r * r;
  return 315.0 / (64.0 * PI * pow(h, 9)) * x * x * x;
}

// gradient of the spiky kernel with respect to xi, for r = xi - xj (points from i toward j)
float3 spiky_gradient(float3 r, float h) {
  const float len = length(r);
  if (len >= h || len < 1e-9) return float3(0, 0, 0);
  const float x = h - len;
  return -45.0 / (PI * pow(h, 6)) * x * x * (r / len);
}

float cohesion_spline(float r, float h) {
  if (r >= h || r <= 0) return 0;
  const float c = 32.0 / (PI * pow(h, 9));
  const float a = (h - r) * (h - r) * (h - r) * r * r * r;
  return r > 0.5 * h ? c * a : c * (2 * a - pow(h, 6) / 64.0);
}

// mass of particle p of a fluid (w is its inverse)
float particle_mass(float4 x) { return x.w > 0 ? 1.0 / x.w : 0; }
