// The visibility test that the culling pass (whole image) and the compute rasterizer (per
// tile) share, so both skip the same instances: a bounding sphere against the frustum of a
// pixel rectangle of a pinhole camera, between its near and far planes.

// the world radius of a mesh's bounding sphere (about its origin) under a scale
float bounding_radius(float mesh_radius, float3 scale) { return mesh_radius * max(abs(scale.x), max(abs(scale.y), abs(scale.z))); }

// centre: in the camera's frame; [lo, hi): pixels
bool sphere_in_view(CameraData c, float3 centre, float radius, float2 lo, float2 hi) {
  if (centre.z + radius < c.clip.x || centre.z - radius > c.clip.y) return false;
  // side planes through the eye and the rectangle's edges: u = x0 is fx x - (x0 - cx) z = 0
  lo -= c.intrinsics.zw;
  hi -= c.intrinsics.zw;
  const float3 planes[4] = {float3(c.intrinsics.x, 0, -lo.x), float3(-c.intrinsics.x, 0, hi.x),
                            float3(0, c.intrinsics.y, -lo.y), float3(0, -c.intrinsics.y, hi.y)};
  for (uint i = 0; i < 4; ++i)
    if (dot(planes[i], centre) < -radius * length(planes[i])) return false;
  return true;
}
